#include "commands.h"
namespace boresight::cli { int runConvert(int, char**) { return 1; } }
