// The precompiled header every test program shares (test/CMakeLists.txt, BORESIGHT_TEST_PCH): what most
// test sources include, parsed once per build instead of once per test source. It only saves time: a
// test source still includes what it uses. .ci/run's sanitizer build compiles its six test folders
// without it (checking them); the other folders are built only with it.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include <boresight/core/pipeline.h>
#include <boresight/core/rotation.h>
#include <boresight/io/core_config.h>
#include <boresight/io/level1.h>
#include <boresight/model/rotation.h>
#include <boresight/model/stats.h>
#include <boresight/sim/output.h>
#include <boresight/sim/scenario.h>
#include <boresight/sim/simulator.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
