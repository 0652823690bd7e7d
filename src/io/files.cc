// Bounded reads, output-path checks, atomic files and output folders (include/boresight/io/files.h).
#include <boresight/io/files.h>

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace boresight::io {
namespace {

std::string why() { return std::strerror(errno); }

bool isDirectory(const std::string& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

/// "a" is "b" or inside it ("b/...").
bool inside(const std::string& a, const std::string& dir) {
  if (dir.empty()) return false;
  if (dir == "/") return a.size() > 1 && a[0] == '/';
  return a.size() > dir.size() && a.compare(0, dir.size(), dir) == 0 && a[dir.size()] == '/';
}

std::string parentOf(const std::string& p) {
  const auto k = p.find_last_of('/');
  if (k == std::string::npos) return ".";
  if (k == 0) return "/";
  return p.substr(0, k);
}

/// Same file on disk (hard links too): both exist with the same device and inode.
bool sameInode(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  return ::stat(a.c_str(), &sa) == 0 && ::stat(b.c_str(), &sb) == 0 && sa.st_dev == sb.st_dev &&
         sa.st_ino == sb.st_ino;
}

mode_t fileMode() {
  static const mode_t m = [] {
    const mode_t u = ::umask(0);
    ::umask(u);
    return static_cast<mode_t>(0666 & ~u);
  }();
  return m;
}

}  // namespace

std::string formatBytes(std::uint64_t b) {
  char buf[64];
  if (b >= (1ull << 30) && b % (1ull << 30) == 0) std::snprintf(buf, sizeof buf, "%llu GiB", static_cast<unsigned long long>(b >> 30));
  else if (b >= (1ull << 20) && b % (1ull << 20) == 0) std::snprintf(buf, sizeof buf, "%llu MiB", static_cast<unsigned long long>(b >> 20));
  else if (b >= (1ull << 10) && b % (1ull << 10) == 0) std::snprintf(buf, sizeof buf, "%llu KiB", static_cast<unsigned long long>(b >> 10));
  else std::snprintf(buf, sizeof buf, "%llu bytes", static_cast<unsigned long long>(b));
  return buf;
}

bool checkInputFile(const std::string& path, std::uint64_t max_bytes, const char* what, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = path + ": " + m;
    return false;
  };
  if (path.empty()) return fail(std::string("empty path for the ") + what);
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return fail("cannot open: " + why());
  if (S_ISDIR(st.st_mode)) return fail(std::string("is a directory, not a ") + what);
  if (S_ISREG(st.st_mode) && static_cast<std::uint64_t>(st.st_size) > max_bytes)
    return fail(std::to_string(st.st_size) + " bytes, more than the limit of " + formatBytes(max_bytes) + " for a " +
                what);
  if (::access(path.c_str(), R_OK) != 0) return fail("cannot open: " + why());
  return true;
}

bool readBounded(const std::string& path, std::uint64_t max_bytes, const char* what, std::string& out,
                 std::string* error) {
  out.clear();
  if (!checkInputFile(path, max_bytes, what, error)) return false;
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) {
    if (error) *error = path + ": cannot open: " + why();
    return false;
  }
  char buf[1 << 16];
  bool over = false, bad = false;
  for (;;) {
    const std::size_t got = std::fread(buf, 1, sizeof buf, f);
    if (got == 0) {
      bad = std::ferror(f) != 0;
      break;
    }
    if (out.size() + got > max_bytes) {
      over = true;
      break;
    }
    out.append(buf, got);
  }
  std::fclose(f);
  if (over) {
    out.clear();
    if (error)
      *error = path + ": more than " + formatBytes(max_bytes) + " (the limit for a " + what +
               "): refused (an endless input?)";
    return false;
  }
  if (bad) {
    out.clear();
    if (error) *error = path + ": read error";
    return false;
  }
  return true;
}

std::string resolvedPath(const std::string& path) {
  if (path.empty()) return {};
  char buf[PATH_MAX];
  if (::realpath(path.c_str(), buf)) return buf;
  // Not there (yet): resolve the deepest existing ancestor, append the rest.
  std::string p = path;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  const auto k = p.find_last_of('/');
  const std::string base = k == std::string::npos ? p : p.substr(k + 1);
  std::string parent = k == std::string::npos ? std::string(".") : (k == 0 ? std::string("/") : p.substr(0, k));
  if (parent == p) return p;  // nothing resolvable
  std::string rp = resolvedPath(parent);
  if (base == "." || base.empty()) return rp;
  if (base == "..") return parentOf(rp);
  return rp == "/" ? "/" + base : rp + "/" + base;
}

bool checkOutputs(const std::vector<std::string>& inputs, const std::vector<OutputPath>& outputs, std::string* error) {
  struct In {
    std::string given, real;
    bool dir;
  };
  std::vector<In> in;
  for (const auto& p : inputs)
    if (!p.empty()) in.push_back({p, resolvedPath(p), isDirectory(p)});
  std::vector<std::pair<const OutputPath*, std::string>> out;
  for (const auto& o : outputs)
    if (!o.path.empty()) out.emplace_back(&o, resolvedPath(o.path));
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  for (std::size_t i = 0; i < out.size(); ++i) {
    const OutputPath& o = *out[i].first;
    const std::string& r = out[i].second;
    const std::string name = o.option + " " + o.path;
    for (const auto& x : in) {
      if (r == x.real || sameInode(o.path, x.given))
        return fail(name + ": is also an input (" + x.given + "): refused, it would be overwritten");
      if (x.dir && inside(r, x.real))
        return fail(name + ": inside the input folder " + x.given + ": refused (it would be read as an input)");
      if (o.directory && x.dir && r == x.real)
        return fail(name + ": is also an input folder (" + x.given + "): refused");
    }
    for (std::size_t j = 0; j < i; ++j) {
      const OutputPath& p = *out[j].first;
      if (r == out[j].second || sameInode(o.path, p.path))
        return fail(p.option + " " + p.path + " and " + name + " name the same file: refused (one would overwrite the other)");
    }
  }
  return true;
}

// ---- AtomicFile ------------------------------------------------------------------------------------

AtomicFile::~AtomicFile() { abandon(); }

bool AtomicFile::open(const std::string& path, std::string* error) {
  abandon();
  path_ = path;
  failed_ = false;
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    if (error) *error = path + ": is a directory: cannot write a file there";
    return false;
  }
  if (::stat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    // A device or a pipe (/dev/null, a FIFO): written directly, never replaced.
    f_ = std::fopen(path.c_str(), "wb");
    if (!f_) {
      if (error) *error = path + ": cannot create: " + why();
      return false;
    }
    tmp_.clear();
    return true;
  }
  tmp_ = path + ".tmp-XXXXXX";
  const int fd = ::mkstemp(tmp_.data());
  if (fd < 0) {
    if (error) *error = path + ": cannot create: " + why();
    tmp_.clear();
    return false;
  }
  ::fchmod(fd, fileMode());
  f_ = ::fdopen(fd, "wb");
  if (!f_) {
    if (error) *error = path + ": cannot create: " + why();
    ::close(fd);
    ::unlink(tmp_.c_str());
    tmp_.clear();
    return false;
  }
  return true;
}

bool AtomicFile::write(std::string_view bytes) {
  if (!f_) return false;
  if (std::fwrite(bytes.data(), 1, bytes.size(), f_) != bytes.size()) failed_ = true;
  return !failed_;
}

bool AtomicFile::commit(std::string* error) {
  if (!f_) {
    if (error) *error = path_ + ": not open";
    return false;
  }
  bool ok = std::fflush(f_) == 0 && !std::ferror(f_) && !failed_;
  ok = std::fclose(f_) == 0 && ok;
  f_ = nullptr;
  if (!ok) {
    if (error) *error = path_ + ": write failed: " + why();
    if (!tmp_.empty()) ::unlink(tmp_.c_str());
    tmp_.clear();
    return false;
  }
  if (tmp_.empty()) return true;  // a device or pipe, written in place
  if (std::rename(tmp_.c_str(), path_.c_str()) != 0) {
    if (error) *error = path_ + ": cannot write (rename of " + tmp_ + " failed: " + why() + ")";
    ::unlink(tmp_.c_str());
    tmp_.clear();
    return false;
  }
  tmp_.clear();
  return true;
}

void AtomicFile::abandon() {
  if (f_) std::fclose(f_);
  f_ = nullptr;
  if (!tmp_.empty()) ::unlink(tmp_.c_str());
  tmp_.clear();
}

bool writeFileAtomic(const std::string& path, std::string_view text, std::string* error) {
  AtomicFile f;
  if (!f.open(path, error)) return false;
  if (!f.write(text)) {
    std::string e;
    f.commit(&e);
    if (error) *error = path + ": write failed";
    return false;
  }
  return f.commit(error);
}

// ---- OutputDir -------------------------------------------------------------------------------------

OutputDir::~OutputDir() {
  if (keep_) return;
  for (auto it = created_.rbegin(); it != created_.rend(); ++it) ::rmdir(it->c_str());  // only if empty
}

bool OutputDir::open(const std::string& path, std::string* error) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) return true;
    if (error) *error = path + ": exists and is not a folder";
    return false;
  }
  // Create the missing folders from the outermost one in.
  std::vector<std::string> missing;
  std::string p = path;
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  while (!p.empty() && p != "." && p != "/" && ::stat(p.c_str(), &st) != 0) {
    missing.push_back(p);
    const auto k = p.find_last_of('/');
    if (k == std::string::npos) break;
    p = p.substr(0, k);
  }
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (::mkdir(it->c_str(), 0777) != 0 && errno != EEXIST) {
      if (error) *error = *it + ": cannot create the folder: " + why();
      return false;
    }
    created_.push_back(*it);
  }
  return true;
}

}  // namespace boresight::io
