#include "tether/core/output_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <climits>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <ostream>
#include <random>
#include <sstream>
#include <streambuf>
#include <vector>

#include "tether/core/error.h"

namespace tether {

namespace {

std::string ErrText(int err) { return err != 0 ? std::string(std::strerror(err)) : std::string("unknown error"); }

// What a user can do about an errno from writing.
std::string Hint(int err) {
  switch (err) {
    case ENOSPC:
    case EDQUOT:
      return "the disk is full (or the quota used up); free some space or write elsewhere";
    case EFBIG:
      return "the file would exceed the file-size limit (ulimit -f); raise it or write elsewhere";
    case EROFS:
      return "the file system is read-only; write elsewhere";
    case EACCES:
    case EPERM:
      return "check the permissions of the file and its folder";
    case EPIPE:
      return "the program reading it went away; keep it reading until tether ends";
    case ENXIO:
      return "nothing is reading the FIFO; start its reader first";
    case ENOENT:
    case ENOTDIR:
      return "check the path";
    default:
      return "check the path and the disk";
  }
}

std::string DirName(const std::string& p) {
  const std::size_t slash = p.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return p.substr(0, slash);
}

std::string BaseName(const std::string& p) {
  const std::size_t slash = p.find_last_of('/');
  return slash == std::string::npos ? p : p.substr(slash + 1);
}

std::string RealPath(const std::string& p) {
  char buf[PATH_MAX];
  if (::realpath(p.c_str(), buf) == nullptr) return "";
  return buf;
}

bool Under(const std::string& canonical, const char* root) {
  const std::size_t n = std::strlen(root);
  return canonical.compare(0, n, root) == 0 && (canonical.size() == n || canonical[n] == '/');
}

// /dev/stdout, /dev/stderr, /dev/fd/N, /proc/self/fd/N, /proc/PID/fd/N (our PID): N, else -1.
int DescriptorOf(const std::string& path) {
  if (path == "/dev/stdout") return 1;
  if (path == "/dev/stderr") return 2;
  std::string rest;
  const std::string own = "/proc/" + std::to_string(static_cast<long>(::getpid())) + "/fd/";
  for (const std::string& prefix : {std::string("/dev/fd/"), std::string("/proc/self/fd/"), own}) {
    if (path.compare(0, prefix.size(), prefix) == 0) rest = path.substr(prefix.size());
  }
  if (rest.empty() || rest.size() > 9 || rest.find_first_not_of("0123456789") != std::string::npos) return -1;
  return std::atoi(rest.c_str());
}

// Follows symbolic links in the last component until it names no link (or nothing).
bool FollowLinks(std::string* path, int* err) {
  for (int hops = 0; hops < 40; ++hops) {
    struct stat st;
    if (::lstat(path->c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return true;
    char buf[PATH_MAX];
    const ssize_t n = ::readlink(path->c_str(), buf, sizeof buf - 1);
    if (n < 0) {
      *err = errno;
      return false;
    }
    std::string link(buf, static_cast<std::size_t>(n));
    *path = (!link.empty() && link[0] == '/') ? link : DirName(*path) + "/" + link;
  }
  *err = ELOOP;
  return false;
}

// Writes all of [data, data + size) to fd; false (errno set) on failure.
bool WriteAll(int fd, const char* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

// An output stream buffer over a file descriptor; remembers the first errno.
class FdBuf : public std::streambuf {
 public:
  explicit FdBuf(int fd) : fd_(fd), buf_(1 << 16) { setp(buf_.data(), buf_.data() + buf_.size()); }
  int error() const { return error_; }

 protected:
  int_type overflow(int_type c) override {
    if (!Drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    if (n < static_cast<std::streamsize>(epptr() - pptr())) {
      std::memcpy(pptr(), s, static_cast<std::size_t>(n));
      pbump(static_cast<int>(n));
      return n;
    }
    if (!Drain() || !Raw(s, static_cast<std::size_t>(n))) return 0;
    return n;
  }
  int sync() override { return Drain() ? 0 : -1; }

 private:
  bool Raw(const char* s, std::size_t n) {
    if (error_ != 0) return false;
    if (!WriteAll(fd_, s, n)) {
      error_ = errno != 0 ? errno : EIO;
      return false;
    }
    return true;
  }
  bool Drain() {
    const std::size_t n = static_cast<std::size_t>(pptr() - pbase());
    setp(buf_.data(), buf_.data() + buf_.size());
    return n == 0 ? error_ == 0 : Raw(buf_.data(), n);
  }

  int fd_;
  std::vector<char> buf_;
  int error_ = 0;
};

std::atomic<unsigned> g_temp_counter{0};

std::string TempName(const std::string& dir, const std::string& base) {
  static thread_local std::mt19937_64 rng(std::random_device{}() ^ static_cast<unsigned long>(::getpid()));
  char tail[64];
  std::snprintf(tail, sizeof tail, ".tether-%ld-%u-%06llx", static_cast<long>(::getpid()), g_temp_counter++,
                static_cast<unsigned long long>(rng() & 0xffffff));
  return dir + "/." + base + tail;
}

struct CommitRecord {
  std::string target, temp, backup;
};

mode_t CurrentUmask() {
  const mode_t m = ::umask(0);
  ::umask(m);
  return m;
}

// The journal of an all-or-nothing commit: per file, "target NUL temp NUL backup NUL" (backup
// empty where the target did not exist), written whole and synced before the first rename.
constexpr const char* kJournalPrefix = ".tether-commit-";
constexpr const char* kJournalSuffix = ".journal";

std::string WriteJournal(const std::string& dir, const std::vector<CommitRecord>& records) {
  std::string text;
  for (const CommitRecord& r : records) {
    for (const std::string* f : {&r.target, &r.temp, &r.backup}) {
      text += *f;
      text.push_back('\0');
    }
  }
  int err = 0;
  for (int attempt = 0; attempt < 100; ++attempt) {
    char tail[64];
    std::snprintf(tail, sizeof tail, "%ld-%u%s", static_cast<long>(::getpid()), g_temp_counter++, kJournalSuffix);
    const std::string name = dir + "/" + kJournalPrefix + tail;
    const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd < 0) {
      err = errno;
      if (err == EEXIST) continue;
      break;
    }
    const bool ok = WriteAll(fd, text.data(), text.size()) && ::fsync(fd) == 0;
    err = errno;
    ::close(fd);
    if (ok) return name;
    ::unlink(name.c_str());
    break;
  }
  throw IoError("'" + dir + "': cannot write the journal that lets an interrupted commit of the outputs be undone (" +
                ErrText(err) + "); " + Hint(err));
}

// True where process `pid` is this one or still runs (its files are not to be touched).
bool Running(long pid) {
  if (pid <= 0) return true;  // not a name of ours
  if (pid == static_cast<long>(::getpid())) return true;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

// Puts the old files back for the first `renamed` records (a new file where there was none is
// removed), removes the temporary files of the rest; returns what the message adds.
std::string UndoRecords(const std::vector<CommitRecord>& records, std::size_t renamed) {
  std::string failed;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const CommitRecord& r = records[i];
    if (i < renamed) {
      const bool ok = r.backup.empty() ? (::unlink(r.target.c_str()) == 0 || errno == ENOENT)
                                       : std::rename(r.backup.c_str(), r.target.c_str()) == 0;
      if (!ok) failed += " '" + r.target + "' (" + ErrText(errno) + ")";
    }
    ::unlink(r.temp.c_str());
  }
  if (records.empty()) return "";
  if (!failed.empty()) return "; could not put back the old" + failed + ": check those files";
  return renamed == 0 ? "; nothing was replaced" : "; every replaced file was put back as it was";
}

}  // namespace

std::vector<std::string> RecoverInterruptedCommits(const std::string& folder) {
  std::vector<std::string> notes;
  DIR* d = ::opendir(folder.c_str());
  if (d == nullptr) return notes;
  std::vector<std::string> journals;
  std::vector<std::string> stale;
  while (const dirent* e = ::readdir(d)) {
    const std::string name = e->d_name;
    if (name.compare(0, std::strlen(kJournalPrefix), kJournalPrefix) == 0 &&
        name.find(kJournalSuffix) != std::string::npos) {
      journals.push_back(name);
      continue;
    }
    // A temporary file or old copy of a process that no longer runs: ".NAME.tether-PID-N-XXXXXX".
    const std::size_t at = name.rfind(".tether-");
    if (name.size() > 1 && name[0] == '.' && at != std::string::npos && at > 0) {
      unsigned long long counter = 0, random = 0;
      long pid = 0;
      int used = 0;
      if (std::sscanf(name.c_str() + at, ".tether-%ld-%llu-%6llx%n", &pid, &counter, &random, &used) == 3 &&
          static_cast<std::size_t>(used) == name.size() - at && !Running(pid)) {
        stale.push_back(name);
      }
    }
  }
  ::closedir(d);
  for (const std::string& name : journals) {
    const long pid = std::atol(name.c_str() + std::strlen(kJournalPrefix));
    if (Running(pid)) continue;
    const std::string path = folder + "/" + name;
    const bool done = name.size() > 5 && name.compare(name.size() - 5, 5, ".done") == 0;
    std::ifstream in(path, std::ios::binary);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::vector<std::string> fields;
    std::size_t start = 0;
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\0') {
        fields.push_back(text.substr(start, i - start));
        start = i + 1;
      }
    }
    std::vector<CommitRecord> records;
    for (std::size_t i = 0; i + 2 < fields.size(); i += 3) records.push_back({fields[i], fields[i + 1], fields[i + 2]});
    std::string targets;
    for (const CommitRecord& r : records) {
      targets += (targets.empty() ? "" : ", ") + BaseName(r.target);
      if (done) {
        // Finished: the new files stand; only the old ones and leftovers go.
        if (!r.backup.empty()) ::unlink(r.backup.c_str());
        ::unlink(r.temp.c_str());
      } else if (!r.backup.empty() && (std::rename(r.backup.c_str(), r.target.c_str()) == 0 || errno != ENOENT)) {
        ::unlink(r.temp.c_str());
      } else {
        // (A backup the journal names but that is not there: the target had vanished when the
        // old file was to be kept, so there was none.)
        // No old file: the target is the new one where it was renamed already, else absent.
        struct stat t, n;
        if (::stat(r.temp.c_str(), &n) != 0 && ::stat(r.target.c_str(), &t) == 0) ::unlink(r.target.c_str());
        ::unlink(r.temp.c_str());
      }
    }
    ::unlink(path.c_str());
    notes.push_back(
        std::string("an earlier run (process ") + std::to_string(pid) + ") was stopped while it " +
        (done ? "cleaned up after replacing" : "replaced") + " its outputs in '" + folder + "' (" + targets +
        "): " + (done ? "its new files stand, the old copies were removed" : "the old files were put back"));
  }
  // After the journals: their records name some of these.
  for (const std::string& name : stale) ::unlink((folder + "/" + name).c_str());
  return notes;
}

struct OutputFile::Staging {
  int fd = -1;
  std::string temp_name;  // named temporary file (empty: unnamed, O_TMPFILE)
  std::string memory;     // in-place targets
  bool ready = false;

  void Close() {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
  void Remove() {
    Close();
    if (!temp_name.empty()) ::unlink(temp_name.c_str());
    temp_name.clear();
    memory.clear();
    ready = false;
  }
};

std::string FileIdentity(const std::string& path) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0) return "";
  return std::to_string(static_cast<unsigned long long>(st.st_dev)) + ":" +
         std::to_string(static_cast<unsigned long long>(st.st_ino));
}

void OutputFile::Fail(const std::string& why, int err) const {
  std::string m = "cannot write the " + what_ + " '" + path_ + "': " + why;
  if (err != 0) m += ": " + ErrText(err) + "; " + Hint(err);
  throw IoError(m);
}

OutputFile::OutputFile(std::string path, std::string what) : path_(std::move(path)), what_(std::move(what)) {
  if (path_.empty()) {
    throw InvalidArgument("the " + what_ + " path is empty; give a file name (is a shell variable unset?)");
  }
  const int fd = DescriptorOf(path_);
  if (fd >= 0) {
    const int flags = ::fcntl(fd, F_GETFL);
    if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY) {
      Fail("descriptor " + std::to_string(fd) + " is not open for writing", flags < 0 ? errno : EBADF);
    }
    struct stat st;
    char_device_ = ::fstat(fd, &st) == 0 && S_ISCHR(st.st_mode);
    identity_ = "fd:" + std::to_string(fd);
    if (::fstat(fd, &st) == 0) {
      identity_ = std::to_string(static_cast<unsigned long long>(st.st_dev)) + ":" +
                  std::to_string(static_cast<unsigned long long>(st.st_ino));
    }
    mode_ = OutputMode::kDescriptor;
    descriptor_ = fd;
    note_ = path_ + " is descriptor " + std::to_string(fd) + ": the " + what_ +
            " is written to it when the command ends (nothing is replaced)";
    return;
  }
  target_ = path_;
  int err = 0;
  if (!FollowLinks(&target_, &err)) Fail("cannot follow its symbolic links", err);
  const std::string dir = DirName(target_);
  const std::string canonical_dir = RealPath(dir);
  if (canonical_dir.empty()) {
    Fail("its folder '" + dir + "' does not exist or cannot be reached; create it first", errno);
  }
  const bool special = Under(canonical_dir, "/proc") || Under(canonical_dir, "/sys");
  if (special) {
    Fail("it is under " + std::string(Under(canonical_dir, "/proc") ? "/proc" : "/sys") +
             ", which holds the system's own files; tether writes there only to /proc/self/fd/N; give a file path",
         0);
  }
  struct stat st;
  if (::stat(target_.c_str(), &st) != 0) {
    if (errno != ENOENT) Fail("cannot look at it", errno);
    identity_ = canonical_dir + "/" + BaseName(target_);
  } else {
    identity_ = std::to_string(static_cast<unsigned long long>(st.st_dev)) + ":" +
                std::to_string(static_cast<unsigned long long>(st.st_ino));
    if (S_ISDIR(st.st_mode)) Fail("it is a folder; give a file name (for example " + path_ + "/out)", 0);
    if (S_ISBLK(st.st_mode))
      Fail("it is a block device; tether does not write into block devices, give a file path", 0);
    if (S_ISSOCK(st.st_mode)) Fail("it is a socket, which cannot be opened as a file; give a file path", 0);
    if (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode)) {
      if (::access(target_.c_str(), W_OK) != 0) Fail("it cannot be opened for writing", errno);
      mode_ = OutputMode::kInPlace;
      char_device_ = S_ISCHR(st.st_mode);
      note_ = path_ + (char_device_ ? " is a character device" : " is a FIFO") + ": the " + what_ +
              " is written into it in place when the command ends (it is not replaced" +
              (char_device_ ? ")" : "; it needs a reader by then)");
      return;
    }
    existing_mode_ = static_cast<unsigned>(st.st_mode & 07777);
  }
  if (::access(canonical_dir.c_str(), W_OK | X_OK) != 0) {
    Fail("its folder '" + dir + "' is not writable", errno);
  }
  if (Under(canonical_dir, "/dev")) {
    note_ = path_ + " is a regular file under /dev: the " + what_ +
            " replaces it through a temporary file beside it, as anywhere else";
  }
}

OutputFile::~OutputFile() {
  if (staging_) staging_->Remove();
}

OutputFile::OutputFile(OutputFile&&) noexcept = default;
OutputFile& OutputFile::operator=(OutputFile&&) noexcept = default;

bool OutputFile::staged() const { return staging_ && staging_->ready; }

void OutputFile::Discard() {
  if (staging_) staging_->Remove();
}

void OutputFile::Stage(std::string_view text) {
  Stage([&](std::ostream& s) { s.write(text.data(), static_cast<std::streamsize>(text.size())); });
}

void OutputFile::Stage(const std::function<void(std::ostream&)>& write) {
  if (committed_) Fail("it was committed already; a committed output cannot be staged again", 0);
  Discard();
  staging_ = std::make_unique<Staging>();
  Staging& s = *staging_;
  if (mode_ != OutputMode::kReplace) {
    std::ostringstream buffer;
    write(buffer);
    if (!buffer) Fail("producing its content failed", 0);
    s.memory = buffer.str();
    s.ready = true;
    return;
  }
  const std::string dir = DirName(target_);
#ifdef O_TMPFILE
  // An unnamed file is given its name at commit through /proc/self/fd; without /proc, a named one.
  if (::access("/proc/self/fd", X_OK) == 0) s.fd = ::open(dir.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0666);
#endif
  if (s.fd < 0) {
    // No unnamed temporary files here (an old kernel, or a file system without them): a
    // named one beside the target, removed on every failure.
    for (int attempt = 0; attempt < 100 && s.fd < 0; ++attempt) {
      s.temp_name = TempName(dir, BaseName(target_));
      s.fd = ::open(s.temp_name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666 & ~CurrentUmask());
      if (s.fd < 0 && errno != EEXIST) break;
    }
    if (s.fd < 0) {
      const int e = errno;
      s.temp_name.clear();
      Fail("cannot create a temporary file in '" + dir + "'", e);
    }
  }
  try {
    FdBuf buf(s.fd);
    std::ostream out(&buf);
    try {
      write(out);
    } catch (...) {
      // A writer that gave up because its stream failed: the stream's own reason is the one.
      if (buf.error() != 0) Fail("writing failed", buf.error());
      throw;
    }
    out.flush();
    if (buf.error() != 0 || !out) {
      const int e = buf.error() != 0 ? buf.error() : EIO;
      Fail("writing failed", e);
    }
    if (existing_mode_ != 0 && ::fchmod(s.fd, static_cast<mode_t>(existing_mode_)) != 0) {
      Fail("cannot keep the existing file's permissions on the new one", errno);
    }
  } catch (...) {
    s.Remove();
    throw;
  }
  s.ready = true;
}

void OutputFile::Prepare() {
  if (committed_) Fail("it was committed already", 0);
  if (!staged()) Fail("nothing was staged for it", 0);
  Staging& s = *staging_;
  if (mode_ != OutputMode::kInPlace || s.fd >= 0) return;
  // Opened without waiting: a FIFO that nobody reads fails here (ENXIO) instead of hanging.
  s.fd = ::open(target_.c_str(), O_WRONLY | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);
  if (s.fd < 0) Fail("cannot open it", errno);
  const int flags = ::fcntl(s.fd, F_GETFL);
  if (flags >= 0) ::fcntl(s.fd, F_SETFL, flags & ~O_NONBLOCK);
}

void OutputFile::Commit() {
  if (committed_) Fail("it was committed already", 0);
  if (!staged()) Fail("nothing was staged for it", 0);
  Staging& s = *staging_;
  if (mode_ == OutputMode::kDescriptor) {
    if (descriptor_ == 1) std::cout.flush();
    if (descriptor_ == 2) std::cerr.flush();
    std::fflush(nullptr);
    if (!WriteAll(descriptor_, s.memory.data(), s.memory.size())) Fail("writing to its descriptor failed", errno);
    s.Remove();
    committed_ = true;
    return;
  }
  if (mode_ == OutputMode::kInPlace) {
    Prepare();
    const bool ok = WriteAll(s.fd, s.memory.data(), s.memory.size());
    const int e = errno;
    const int closed = ::close(s.fd);
    const int close_errno = errno;
    s.fd = -1;
    s.Remove();
    if (!ok) Fail("writing into it failed", e);
    if (closed != 0) Fail("closing it failed", close_errno);
    committed_ = true;
    return;
  }
  NameStaged();
  RenameStaged();
}

const std::string& OutputFile::NameStaged() {
  Staging& s = *staging_;
  const std::string dir = DirName(target_);
  if (s.temp_name.empty()) {
    // An unnamed temporary file: give it a name beside the target, then rename that.
    const std::string fd_path = "/proc/self/fd/" + std::to_string(s.fd);
    int e = 0;
    for (int attempt = 0; attempt < 100; ++attempt) {
      const std::string name = TempName(dir, BaseName(target_));
      if (::linkat(AT_FDCWD, fd_path.c_str(), AT_FDCWD, name.c_str(), AT_SYMLINK_FOLLOW) == 0) {
        s.temp_name = name;
        break;
      }
      e = errno;
      if (e != EEXIST) break;
    }
    if (s.temp_name.empty()) {
      s.Remove();
      Fail("cannot give the temporary file a name in '" + dir + "'", e);
    }
  }
  s.Close();
  return s.temp_name;
}

void OutputFile::RenameStaged() {
  Staging& s = *staging_;
  if (std::rename(s.temp_name.c_str(), target_.c_str()) != 0) {
    const int e = errno;
    s.Remove();
    Fail("cannot rename the temporary file over it", e);
  }
  s.temp_name.clear();
  s.ready = false;
  committed_ = true;
}

void OutputSet::AddInput(const std::string& path, const std::string& what) {
  if (path.empty()) return;
  const std::string id = FileIdentity(path);
  if (!id.empty()) inputs_.push_back({path, what, id});
}

OutputFile& OutputSet::Add(const std::string& path, const std::string& what) {
  auto out = std::make_unique<OutputFile>(path, what);
  if (out->mode() == OutputMode::kReplace) {
    const std::string folder = DirName(out->target());
    if (std::find(checked_folders_.begin(), checked_folders_.end(), folder) == checked_folders_.end()) {
      checked_folders_.push_back(folder);
      for (std::string& note : RecoverInterruptedCommits(folder)) recovered_.push_back(std::move(note));
    }
  }
  for (const Input& in : inputs_) {
    if (in.identity == out->identity()) {
      throw InvalidArgument("the " + what + " '" + path + "' is the " + in.what + " '" + in.path +
                            "'; tether does not write over what it reads: give the " + what +
                            " another path (or, where the command names its outputs itself, another folder)");
    }
  }
  for (const auto& other : outputs_) {
    if (other->identity() == out->identity() && !(out->char_device() && other->char_device())) {
      const std::string also = other->path() == path ? "" : " (as '" + other->path() + "')";
      throw InvalidArgument("the " + what + " and the " + other->what() + " both name '" + path + "'" + also +
                            "; give each output its own path");
    }
  }
  outputs_.push_back(std::move(out));
  return *outputs_.back();
}

std::vector<std::string> OutputSet::Notes() const {
  std::vector<std::string> notes = recovered_;
  for (const auto& o : outputs_) {
    if (!o->note().empty()) notes.push_back(o->note());
  }
  return notes;
}

void OutputSet::CommitAll() {
  std::vector<OutputFile*> files, devices;
  for (const auto& o : outputs_) {
    if (!o->staged()) continue;
    (o->mode() == OutputMode::kReplace ? files : devices).push_back(o.get());
  }
  try {
    // Devices and FIFOs are opened first, so one that cannot be (a FIFO without a reader)
    // fails before any file is replaced.
    for (OutputFile* o : devices) o->Prepare();
    if (files.empty() || (files.size() == 1 && devices.empty())) {
      // One rename is all or nothing by itself; devices alone have nothing to put back.
      for (OutputFile* o : files) o->Commit();
      for (OutputFile* o : devices) o->Commit();
      return;
    }
  } catch (const IoError& e) {
    DiscardAll();
    throw IoError(std::string(e.what()) + "; nothing was replaced");
  } catch (...) {
    DiscardAll();
    throw;
  }
  CommitFiles(files, devices);
}

namespace {

// Links `target` to `*backup`; true on success. Another process may rename a file over the
// target at the same moment, and Linux then refuses the link (ENOENT: the inode it found has
// just lost its last name) though the target stands: the link is tried again on what is there
// now. Where the target is really gone, there is no old file to keep: `*backup` is cleared.
bool KeepOldFile(const std::string& target, std::string* backup) {
  for (int attempt = 0; attempt < 1000; ++attempt) {
    if (::link(target.c_str(), backup->c_str()) == 0) return true;
    if (errno != ENOENT) return false;
    struct stat st;
    if (::lstat(target.c_str(), &st) != 0) {
      backup->clear();
      return true;
    }
  }
  errno = ENOENT;
  return false;
}

}  // namespace

void OutputSet::CommitFiles(const std::vector<OutputFile*>& files, const std::vector<OutputFile*>& devices) {
  std::vector<CommitRecord> records;
  std::string journal;
  std::size_t renamed = 0;
  // Tests only: SIGKILL before the N-th rename (N = the number of files: after the commit
  // point, before the clean-up), to check what a later run makes of it.
  const char* kill_after = std::getenv("TETHER_TEST_KILL_AFTER_RENAMES");
  const auto undo = [&](const std::string& why) {
    std::string back = UndoRecords(records, renamed);
    for (const CommitRecord& r : records) {
      if (!r.backup.empty()) ::unlink(r.backup.c_str());
    }
    if (!journal.empty()) ::unlink(journal.c_str());
    DiscardAll();
    return why + back;
  };
  try {
    for (OutputFile* o : files) {
      CommitRecord r;
      r.target = o->target();
      r.temp = o->NameStaged();
      records.push_back(r);
    }
    // A hard link keeps each old file under another name; renaming the new one over the
    // target then leaves it there, to be put back. The names are in the journal before any
    // link is made, so that a process killed from here on leaves nothing a later run cannot
    // clear up.
    for (CommitRecord& r : records) {
      struct stat st;
      if (::lstat(r.target.c_str(), &st) == 0) r.backup = TempName(DirName(r.target), BaseName(r.target));
    }
    journal = WriteJournal(DirName(records.front().target), records);
    for (CommitRecord& r : records) {
      if (r.backup.empty() || KeepOldFile(r.target, &r.backup)) continue;
      const int err = errno;
      throw IoError("'" + r.target + "': cannot keep the old file under another name while the new set of outputs " +
                    "is put in place (" + ErrText(err) + "); " + Hint(err));
    }

    for (OutputFile* o : files) {
      if (kill_after != nullptr && static_cast<long>(renamed) == std::atol(kill_after)) ::raise(SIGKILL);
      o->RenameStaged();
      ++renamed;
    }
    for (OutputFile* o : devices) o->Commit();
  } catch (const IoError& e) {
    throw IoError(undo(e.what()));
  } catch (...) {
    undo("");
    throw;
  }
  // The commit point: the journal says "done" (an interrupted clean-up is finished, never
  // undone), then the old files and the journal go.
  const std::string done = journal + ".done";
  if (std::rename(journal.c_str(), done.c_str()) != 0) {
    // Without it the old files could be put back by a later run: keep them all, undo.
    const int e = errno;
    throw IoError(undo("cannot mark the commit of the outputs finished in '" + journal + "' (" + ErrText(e) + ")"));
  }
  if (kill_after != nullptr && std::atol(kill_after) == static_cast<long>(files.size())) ::raise(SIGKILL);
  for (const CommitRecord& r : records) {
    if (!r.backup.empty()) ::unlink(r.backup.c_str());
  }
  ::unlink(done.c_str());
}

void OutputSet::DiscardAll() {
  for (const auto& o : outputs_) o->Discard();
}

void WriteTextFile(const std::string& path, std::string_view text, const std::string& what) {
  OutputFile out(path, what);
  out.Stage(text);
  out.Commit();
}

}  // namespace tether
