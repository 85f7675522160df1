// The fly-through's output folder: checked before any work, held by one run at a time (a lock
// file naming the holder's pid), every file written under a temporary name and renamed into
// place, every write checked.
#pragma once

#include <optional>
#include <string>

namespace engine {
struct CpuImage;
}

namespace world {

/// Checks, without creating anything, that `dir` can be used as the output folder: an existing
/// writable directory, or a path whose nearest existing ancestor is a writable directory.
/// Returns the refusal (naming --out, the path and why), or nothing. A probe file is created and
/// removed to test writability (access() says yes to root on read-only folders).
[[nodiscard]] std::optional<std::string> checkOutputDir(const std::string& dir);

/// Creates `dir` and holds it: DIR/.csm_flythrough.lock, created exclusively, holds our pid. A
/// lock left by a process that no longer exists is taken over; one held by a live process is
/// refused. Released (the lock file removed) by the destructor.
class OutputDirLock {
 public:
  OutputDirLock() = default;
  OutputDirLock(const OutputDirLock&) = delete;
  OutputDirLock& operator=(const OutputDirLock&) = delete;
  ~OutputDirLock();
  /// Returns the refusal, or nothing when the folder is now ours.
  [[nodiscard]] std::optional<std::string> acquire(const std::string& dir);
  [[nodiscard]] const std::string& lockPath() const noexcept { return lockPath_; }

 private:
  std::string lockPath_;
};

/// Writes `bytes` to `path` through `path.tmp-PID` and a rename; returns the error, or nothing.
[[nodiscard]] std::optional<std::string> writeFileAtomically(const std::string& path,
                                                             const std::string& bytes);

/// The same for a PNG (engine::writePng into the temporary name, checked).
[[nodiscard]] std::optional<std::string> writePngAtomically(const std::string& path,
                                                            const engine::CpuImage& image);

}  // namespace world
