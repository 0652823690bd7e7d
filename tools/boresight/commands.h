// The subcommands of the `boresight` program. Each lives in its own cmd_*.cc file and is listed once
// in main.cc. A command returns the process exit status: 0 success, 1 failure, 2 usage error.
#pragma once

namespace boresight::cli {

int runInspect(int argc, char** argv);
int runConvert(int argc, char** argv);
int runProcess(int argc, char** argv);
int runSimulate(int argc, char** argv);
int runPlot(int argc, char** argv);
int runCalibrate(int argc, char** argv);
int runGround(int argc, char** argv);
int runSimulateGround(int argc, char** argv);
int runAudit(int argc, char** argv);
int runNoise(int argc, char** argv);
int runBound(int argc, char** argv);

}  // namespace boresight::cli
