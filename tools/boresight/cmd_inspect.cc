#include "commands.h"
namespace boresight::cli { int runInspect(int, char**) { return 1; } }
