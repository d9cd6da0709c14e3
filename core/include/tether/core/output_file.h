#pragma once
// The one writer of every file tether produces (graphs, plots, covariances, tables).
//
// An output is checked when it is named, staged while the command works, and committed at
// the end, so a failure anywhere leaves every target as it was:
//
//   OutputSet outputs;
//   outputs.AddInput("in.g2o");                      // outputs may not overwrite it
//   OutputFile& graph = outputs.Add("out.g2o", "optimised graph");  // checked now (IoError)
//   OutputFile& plot = outputs.Add("out.svg", "plot");
//   ... long work ...
//   graph.Stage([&](std::ostream& s) { WriteG2o(s, ...); });
//   plot.Stage(svg_text);
//   outputs.CommitAll();                             // renames (or writes in place) last
//
// What a path gets (docs/outputs.md):
// - a new path or a regular file: the content goes to a temporary file in the target's own
//   folder (unnamed where the system allows, so a killed process leaves nothing behind) and is
//   renamed over the target; an existing file's permission bits are kept. A symbolic link is
//   followed: its target is replaced, the link stays.
// - a character device or a FIFO (/dev/null, a pipe from `>(gzip > x)`), and /dev/stdout,
//   /dev/stderr, /dev/fd/N, /proc/self/fd/N: written in place at commit (the descriptor
//   itself for the last four), never replaced.
// - refused, with a message saying what to do: an empty path, a folder, a folder that does not
//   exist or cannot be written, a block device, a socket, any other path under /proc or /sys,
//   an output that names an input or another output (a character device may be named twice).
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace tether {

/// How an output path will be written.
enum class OutputMode {
  kReplace,     ///< temporary file in the target's folder, renamed over it at commit
  kInPlace,     ///< a device or FIFO, opened and written at commit
  kDescriptor,  ///< /dev/stdout, /dev/stderr, /dev/fd/N, /proc/self/fd/N: that descriptor
};

class OutputFile {
 public:
  /// Checks `path` (see the header comment) and says how it will be written. `what` names the
  /// output in messages ("optimised graph", "plot"). Throws IoError (InvalidArgument for an
  /// empty path) whose message names the path and what to do. Creates nothing.
  OutputFile(std::string path, std::string what);
  ~OutputFile();  ///< removes a staged temporary file that was not committed
  OutputFile(OutputFile&&) noexcept;
  OutputFile& operator=(OutputFile&&) noexcept;
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  const std::string& path() const { return path_; }
  const std::string& what() const { return what_; }
  OutputMode mode() const { return mode_; }
  /// The file that will be replaced (the path with symbolic links followed), for kReplace.
  const std::string& target() const { return target_; }
  /// For a path under /dev, /proc or /sys, or any target that is not replaced, one line
  /// saying what will be done ("/dev/null is a character device: written in place ...");
  /// empty otherwise.
  const std::string& note() const { return note_; }
  /// A character device (/dev/null): two outputs may name the same one.
  bool char_device() const { return char_device_; }

  /// Stages the content: `write` fills the stream (it may throw; nothing is then staged). The
  /// stream's write errors (disk full, file too large) are reported as IoError naming the
  /// path. Staging again replaces what was staged.
  void Stage(const std::function<void(std::ostream&)>& write);
  void Stage(std::string_view text);
  bool staged() const;

  /// Opens an in-place target (device, FIFO) without writing, so that one that cannot be
  /// opened fails before other outputs are committed; nothing for other targets. Throws IoError.
  void Prepare();
  /// Makes the staged content the target's: rename over it, or write in place. Throws IoError
  /// naming the path; a temporary file is removed on failure. Committing twice, or without
  /// staging, is an error.
  void Commit();
  bool committed() const { return committed_; }

  /// Drops what was staged (the temporary file is removed); the target is untouched.
  void Discard();

  /// Identity of the target, for comparing outputs with each other and with inputs:
  /// "dev:inode" of an existing file, else the canonical path it will be created at.
  const std::string& identity() const { return identity_; }

 private:
  friend class OutputSet;
  struct Staging;
  void Fail(const std::string& why, int err) const;
  // The two halves of committing a kReplace output, for OutputSet's all-or-nothing commit:
  // give the staged temporary file a name beside the target (returned), then rename it over
  // the target.
  const std::string& NameStaged();
  void RenameStaged();

  std::string path_, what_, target_, note_, identity_;
  OutputMode mode_ = OutputMode::kReplace;
  int descriptor_ = -1;         // kDescriptor
  unsigned existing_mode_ = 0;  // permission bits of an existing regular target, 0 if new
  bool char_device_ = false;
  bool committed_ = false;
  std::unique_ptr<Staging> staging_;
};

/// Every output of one command: checked against each other and against the inputs as they
/// are added, committed together.
class OutputSet {
 public:
  /// A file the command reads; an output that names it is refused. A path that does not exist
  /// is ignored (the reader reports it).
  void AddInput(const std::string& path, const std::string& what = "input");
  /// Checks the path (OutputFile) and that it names neither an input nor another output.
  /// Throws IoError / InvalidArgument. The reference stays valid while the set lives.
  OutputFile& Add(const std::string& path, const std::string& what);
  /// Notes of every output (OutputFile::note), one per line, for the command to print.
  std::vector<std::string> Notes() const;
  /// Commits every staged output as one set: either all of them are replaced, or none is.
  /// Devices and FIFOs are opened first (a FIFO without a reader fails before anything is
  /// replaced). With two or more files, a journal (".tether-commit-*.journal" in the first
  /// file's folder) lists them and a hard link keeps each old file before any is renamed over;
  /// a failure part-way renames every old file back (and removes the new ones that had none),
  /// and the IoError says so. Devices and FIFOs are written after the files, before the journal
  /// is dropped (a failure there puts the files back too; what a device received stays). A
  /// process killed part-way leaves the journal: the next OutputSet that adds an output in
  /// that folder finishes the commit where it had been completed, else puts the old files back
  /// (Notes() says which). Outputs not staged are skipped; what was staged and not committed is
  /// discarded.
  void CommitAll();
  /// Drops everything staged.
  void DiscardAll();

 private:
  struct Input {
    std::string path, what, identity;
  };
  std::vector<Input> inputs_;
  std::vector<std::unique_ptr<OutputFile>> outputs_;
  void CommitFiles(const std::vector<OutputFile*>& files, const std::vector<OutputFile*>& devices);
  std::vector<std::string> recovered_;        // notes of interrupted commits finished or undone
  std::vector<std::string> checked_folders_;  // folders already searched for journals
};

/// Finishes or undoes the commits interrupted in `folder` (journals of processes no longer
/// running; see OutputSet::CommitAll) and returns one note per journal handled. Never throws.
std::vector<std::string> RecoverInterruptedCommits(const std::string& folder);

/// Identity of an existing file ("dev:inode"), or "" where it cannot be stat'ed.
std::string FileIdentity(const std::string& path);

/// Writes `text` to `path` through one OutputFile (staged and committed at once).
void WriteTextFile(const std::string& path, std::string_view text, const std::string& what);

}  // namespace tether
