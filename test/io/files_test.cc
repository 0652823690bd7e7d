// Inputs and outputs (io/files.h): bounded reads refuse directories and endless inputs with the limit,
// output paths that are inputs (also through a link), two outputs on one path and outputs inside an
// input folder are refused, atomic files leave the previous file or nothing, an output folder a
// failed run created is removed.
#include <boresight/io/files.h>

#include "test_files.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <unistd.h>

using namespace boresight;

namespace {

bool exists(const std::string& p) { return ::access(p.c_str(), F_OK) == 0; }

std::size_t filesIn(const std::string& dir) {
  std::size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) n += e.is_regular_file() ? 1 : 0;
  return n;
}

}  // namespace

TEST(BoundedRead, RefusesADirectoryAndAnEndlessInputWithTheLimit) {
  const std::string dir = testutil::makeTempDir("files_read");
  std::string text, err;
  EXPECT_FALSE(io::readBounded(dir, 1024, "configuration file", text, &err));
  EXPECT_NE(err.find("is a directory, not a configuration file"), std::string::npos) << err;
  // /dev/zero never ends: refused after limit + 1 bytes, with the limit in the message.
  EXPECT_FALSE(io::readBounded("/dev/zero", 1u << 20, "scenario file", text, &err));
  EXPECT_NE(err.find("more than 1 MiB (the limit for a scenario file)"), std::string::npos) << err;
  EXPECT_TRUE(text.empty());
  // A regular file above the limit is refused before it is read.
  ASSERT_TRUE(testutil::writeFile(dir + "/big.yaml", std::string(5000, 'x')));
  EXPECT_FALSE(io::readBounded(dir + "/big.yaml", 4096, "configuration file", text, &err));
  EXPECT_NE(err.find("5000 bytes, more than the limit of 4 KiB"), std::string::npos) << err;
  EXPECT_TRUE(io::readBounded(dir + "/big.yaml", 5000, "configuration file", text, &err)) << err;
  EXPECT_EQ(text.size(), 5000u);
  EXPECT_FALSE(io::readBounded(dir + "/missing.yaml", 5000, "configuration file", text, &err));
  EXPECT_NE(err.find("missing.yaml: cannot open"), std::string::npos) << err;
}

TEST(CheckOutputs, AnOutputThatIsAnInputIsRefusedAlsoThroughALink) {
  const std::string dir = testutil::makeTempDir("files_out");
  const std::string in = dir + "/in.lcm";
  ASSERT_TRUE(testutil::writeFile(in, "data"));
  std::string err;
  EXPECT_FALSE(io::checkOutputs({in}, {{"--record", in}}, &err));
  EXPECT_NE(err.find("--record " + in + ": is also an input"), std::string::npos) << err;
  // The same file by another name: a relative path with "..", a symbolic link, a hard link.
  EXPECT_FALSE(io::checkOutputs({in}, {{"--out", dir + "/sub/../in.lcm"}}, &err));
  ASSERT_EQ(::symlink(in.c_str(), (dir + "/sym.lcm").c_str()), 0);
  EXPECT_FALSE(io::checkOutputs({dir + "/sym.lcm"}, {{"--out", in}}, &err));
  ASSERT_EQ(::link(in.c_str(), (dir + "/hard.lcm").c_str()), 0);
  EXPECT_FALSE(io::checkOutputs({in}, {{"--out", dir + "/hard.lcm"}}, &err));
  EXPECT_NE(err.find("is also an input"), std::string::npos) << err;
  // Two outputs on one path.
  EXPECT_FALSE(io::checkOutputs({in}, {{"--out", dir + "/a.csv"}, {"--stars-out", dir + "/./a.csv"}}, &err));
  EXPECT_NE(err.find("--out " + dir + "/a.csv and --stars-out"), std::string::npos) << err;
  EXPECT_NE(err.find("name the same file"), std::string::npos) << err;
  // An output inside an input folder (inspect reads folders), an output folder that holds an input.
  EXPECT_FALSE(io::checkOutputs({dir}, {{"--json", dir + "/x/inspect.json"}}, &err));
  EXPECT_NE(err.find("inside the input folder"), std::string::npos) << err;
  EXPECT_FALSE(io::checkOutputs({dir}, {{"--out", dir, true}}, &err));
  EXPECT_NE(err.find("is also an input"), std::string::npos) << err;
  // What is fine stays fine: distinct files, empty (absent) options.
  EXPECT_TRUE(io::checkOutputs({in}, {{"--out", dir + "/a.csv"}, {"--stars-out", ""}, {"--report", dir + "/r", true}}, &err))
      << err;
}

TEST(AtomicFile, AFailedWriteLeavesThePreviousFileAndNoTemporary) {
  const std::string dir = testutil::makeTempDir("files_atomic");
  const std::string p = dir + "/out.csv";
  ASSERT_TRUE(testutil::writeFile(p, "previous\n"));
  {
    io::AtomicFile f;
    std::string err;
    ASSERT_TRUE(f.open(p, &err)) << err;
    ASSERT_TRUE(f.write("half a li"));
    EXPECT_EQ(testutil::slurp(p), "previous\n");  // not visible while written
    EXPECT_EQ(filesIn(dir), 2u);                  // the temporary one beside it
  }  // destroyed without commit: an error path
  EXPECT_EQ(testutil::slurp(p), "previous\n");
  EXPECT_EQ(filesIn(dir), 1u);
  std::string err;
  ASSERT_TRUE(io::writeFileAtomic(p, "new\n", &err)) << err;
  EXPECT_EQ(testutil::slurp(p), "new\n");
  EXPECT_EQ(filesIn(dir), 1u);
  // A device is written in place, never replaced.
  EXPECT_TRUE(io::writeFileAtomic("/dev/null", "x", &err)) << err;
  struct stat st {};
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  // A directory cannot be an output file.
  EXPECT_FALSE(io::writeFileAtomic(dir, "x", &err));
  EXPECT_NE(err.find("is a directory"), std::string::npos) << err;
}

TEST(OutputDir, AFailedRunRemovesTheEmptyFolderItCreatedButNeverAnExistingOne) {
  const std::string dir = testutil::makeTempDir("files_dir");
  std::string err;
  {
    io::OutputDir d;
    ASSERT_TRUE(d.open(dir + "/a/b", &err)) << err;
    EXPECT_TRUE(exists(dir + "/a/b"));
  }
  EXPECT_FALSE(exists(dir + "/a"));
  {
    io::OutputDir d;
    ASSERT_TRUE(d.open(dir + "/kept", &err)) << err;
    d.keep();
  }
  EXPECT_TRUE(exists(dir + "/kept"));
  {
    io::OutputDir d;  // exists already: never removed
    ASSERT_TRUE(d.open(dir + "/kept", &err)) << err;
  }
  EXPECT_TRUE(exists(dir + "/kept"));
  ASSERT_TRUE(testutil::writeFile(dir + "/file", "x"));
  io::OutputDir d;
  EXPECT_FALSE(d.open(dir + "/file", &err));
  EXPECT_NE(err.find("exists and is not a folder"), std::string::npos) << err;
}
