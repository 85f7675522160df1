// The fly-through's output folder (see output_dir.hpp).
#include "sample_world/output_dir.hpp"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "engine/image_io.hpp"

namespace world {

namespace fs = std::filesystem;

namespace {

/// Creates and removes a probe file in `dir`: the error text, or nothing when writable.
std::optional<std::string> probeWritable(const fs::path& dir) {
  const fs::path probe = dir / (".csm_flythrough.probe-" + std::to_string(::getpid()));
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return std::string(std::strerror(errno));
  ::close(fd);
  ::unlink(probe.c_str());
  return std::nullopt;
}

std::string tempName(const std::string& path) {
  return path + ".tmp-" + std::to_string(::getpid());
}

std::optional<std::string> renameInto(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  fs::rename(tmp, path, ec);
  if (ec) {
    fs::remove(tmp, ec);
    return "cannot rename " + tmp + " to " + path + " (" + ec.message() + ")";
  }
  return std::nullopt;
}

}  // namespace

std::optional<std::string> checkOutputDir(const std::string& dir) {
  if (dir.empty()) return std::string("--out: the path is empty (allowed a writable folder)");
  std::error_code ec;
  const fs::path p(dir);
  const fs::file_status st = fs::status(p, ec);
  if (fs::exists(st)) {
    if (!fs::is_directory(st)) return "--out " + dir + ": exists and is not a folder";
    if (auto e = probeWritable(p))
      return "--out " + dir + ": the folder is not writable (" + *e + ")";
    return std::nullopt;
  }
  // Does not exist yet: its nearest existing ancestor must be a writable folder.
  fs::path parent = fs::absolute(p, ec).parent_path();
  while (!parent.empty()) {
    const fs::file_status ps = fs::status(parent, ec);
    if (fs::exists(ps)) {
      if (!fs::is_directory(ps)) {
        return "--out " + dir + ": cannot be created, " + parent.string() + " is not a folder";
      }
      if (auto e = probeWritable(parent)) {
        return "--out " + dir + ": cannot be created in " + parent.string() + " (" + *e + ")";
      }
      return std::nullopt;
    }
    if (parent == parent.parent_path()) break;
    parent = parent.parent_path();
  }
  return "--out " + dir + ": no existing folder to create it in";
}

OutputDirLock::~OutputDirLock() {
  if (!lockPath_.empty()) ::unlink(lockPath_.c_str());
}

std::optional<std::string> OutputDirLock::acquire(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return "--out " + dir + ": cannot create the folder (" + ec.message() + ")";
  const std::string lock = (fs::path(dir) / ".csm_flythrough.lock").string();
  for (int attempt = 0; attempt < 2; ++attempt) {
    const int fd = ::open(lock.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd >= 0) {
      const std::string pid = std::to_string(::getpid()) + "\n";
      const bool ok = ::write(fd, pid.data(), pid.size()) == static_cast<ssize_t>(pid.size());
      ::close(fd);
      if (!ok) {
        ::unlink(lock.c_str());
        return "--out " + dir + ": cannot write the lock file " + lock;
      }
      lockPath_ = lock;
      return std::nullopt;
    }
    if (errno != EEXIST) {
      return "--out " + dir + ": cannot create the lock file " + lock + " (" +
             std::strerror(errno) + ")";
    }
    // Held: by a live process (refused) or left behind by one that died (taken over).
    long holder = 0;
    {
      std::ifstream in(lock);
      in >> holder;
    }
    if (holder > 0 && (::kill(static_cast<pid_t>(holder), 0) == 0 || errno == EPERM)) {
      return "--out " + dir + ": another csm_flythrough (pid " + std::to_string(holder) +
             ") is writing into this folder (lock file " + lock +
             "); use another --out or wait for it to finish";
    }
    ::unlink(lock.c_str());
  }
  return "--out " + dir + ": cannot take over the stale lock file " + lock;
}

std::optional<std::string> writeFileAtomically(const std::string& path, const std::string& bytes) {
  const std::string tmp = tempName(path);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) return "cannot create " + tmp + " (" + std::strerror(errno) + ")";
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::error_code ec;
      fs::remove(tmp, ec);
      return "cannot write " + tmp + " (disk full?)";
    }
  }
  return renameInto(tmp, path);
}

std::optional<std::string> writePngAtomically(const std::string& path,
                                              const engine::CpuImage& image) {
  const std::string tmp = tempName(path);
  if (!engine::writePng(tmp, image)) {
    std::error_code ec;
    fs::remove(tmp, ec);
    return "cannot write the PNG " + tmp;
  }
  return renameInto(tmp, path);
}

}  // namespace world
