#pragma once
// Outputs are never half-written and never destroy anything that is not an earlier output of the same kind:
// they are produced under a temporary name in the destination folder and renamed into place only once
// complete (rename is atomic within one file system). Rules (doc/reliability.md):
//   - a file output replaces an existing regular file (or a symbolic link to one), never a folder or a
//     special file (device, pipe, socket);
//   - a folder output replaces an existing folder only when it is empty or holds nothing but the files that
//     kind of output writes (OutputKind::folder's pattern), never a file or a symbolic link;
//   - no output may be one of the run's inputs, nor a folder holding one (OutputSet);
//   - the temporaries of live outputs are removed when the process is ended by SIGINT, SIGTERM or SIGHUP
//     (installOutputCleanupOnSignals), then the signal ends the process as it would have without it.
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace pslam {

/// What an output is: a file, or a folder of files whose names match a pattern (ECMAScript regular
/// expression over the whole file name). An existing path is replaced only by the same kind of output.
class OutputKind {
 public:
  static OutputKind file() { return OutputKind(false, {}); }
  static OutputKind folder(std::string entryPattern) { return OutputKind(true, std::move(entryPattern)); }
  bool isFolder() const { return folder_; }
  const std::string& entryPattern() const { return pattern_; }

 private:
  OutputKind(bool folder, std::string pattern) : folder_(folder), pattern_(std::move(pattern)) {}
  bool folder_;
  std::string pattern_;
};

/// Throws pslam::Error naming `path` unless an output of `kind` may be created or may replace what exists
/// there (rules at the top of this file).
void requireReplaceable(const std::filesystem::path& path, const OutputKind& kind);

/// RAII guard for one output path. The constructor checks that the output may be written there, creates the
/// parent folder and reserves the temporary (an empty file, or an empty folder for a folder output), so a run
/// fails before its work when an output is impossible. Write to tempPath(); commit() renames it onto
/// finalPath(). If the guard is destroyed without commit() (an exception, an early return), the temporary is
/// removed; while it lives it is also removed if a signal ends the process.
class AtomicOutput {
 public:
  explicit AtomicOutput(std::filesystem::path finalPath, OutputKind kind = OutputKind::file());
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::filesystem::path& tempPath() const { return temp_; }
  const std::filesystem::path& finalPath() const { return final_; }
  const OutputKind& kind() const { return kind_; }
  /// Throws pslam::Error if finalPath() now holds something this output may not replace.
  void checkReplaceable() const { requireReplaceable(final_, kind_); }
  /// Replaces finalPath() (checked again) with tempPath(). Throws pslam::Error on failure; the previous
  /// content of finalPath() is then left as it was.
  void commit();
  bool committed() const { return committed_; }

 private:
  std::filesystem::path final_;
  std::filesystem::path temp_;
  OutputKind kind_;
  int registrySlot_ = -1;
  bool committed_ = false;
};

/// Throws pslam::Error("<output>: is the input <input>; refusing to overwrite an input") when `output` is
/// one of `inputs` (the same path after resolving symbolic links, `.` and `..`, or the same file), or, for a
/// folder output, holds one of them. Empty paths in `inputs` are ignored.
void requireNotAnInput(const std::filesystem::path& output, const OutputKind& kind,
                       const std::vector<std::filesystem::path>& inputs);

/// The outputs of one run of a tool: all are prepared before the work (each checked against the inputs,
/// against the others and against what exists on disk), and committed together at the end, so a run
/// publishes all of its outputs or none. commit() checks every output again before it moves the first one.
class OutputSet {
 public:
  explicit OutputSet(std::vector<std::filesystem::path> inputs = {});
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  /// Prepares one more output (an AtomicOutput owned by the set). Throws pslam::Error naming the path if it
  /// is an input, is given twice, or may not replace what exists there.
  AtomicOutput& add(const std::filesystem::path& finalPath, OutputKind kind = OutputKind::file());
  const std::vector<std::filesystem::path>& inputs() const { return inputs_; }
  /// Checks every output again, then moves each into place.
  void commit();

 private:
  std::vector<std::filesystem::path> inputs_;
  std::vector<std::unique_ptr<AtomicOutput>> outputs_;
};

/// Writes a text/binary file atomically through `writer`. Throws pslam::Error naming the path on failure.
void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(std::ostream&)>& writer);
/// Writes through `writer` into the temporary of `output` (committed later by its owner).
void writeOutputFile(const AtomicOutput& output, const std::function<void(std::ostream&)>& writer);

/// Creates the parent folder of `path` if needed (no-op for a bare file name).
void ensureParentDirectory(const std::filesystem::path& path);

/// Installs, once per process, a handler for SIGINT, SIGTERM and SIGHUP that removes the temporaries of the
/// live AtomicOutputs and then ends the process with the same signal (default action). A signal whose
/// disposition is not the default (ignored, or handled by the embedding program) is left alone. Called by the
/// first AtomicOutput; tools may call it earlier. The handler only uses async-signal-safe calls: unlink for
/// files; for folders, it removes the files directly inside (our folder outputs are flat) and then the folder.
/// At most 64 temporaries with paths shorter than 4096 bytes are tracked at a time; others are still
/// removed by their destructor, not by the handler.
void installOutputCleanupOnSignals();

}  // namespace pslam
