#include "bench_common.h"

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <sstream>

#include "tether/core/enum_names.h"
#include "tether/core/error.h"
#include "tether/core/output_file.h"

namespace tether {
namespace bench {

namespace {

namespace fs = std::filesystem;

bool WriteAll(int fd, const std::string& s) {
  std::size_t done = 0;
  while (done < s.size()) {
    const ssize_t n = ::write(fd, s.data() + done, s.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

std::string ReadAllFd(int fd) {
  std::string s;
  char buf[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof(buf));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    s.append(buf, static_cast<std::size_t>(n));
  }
  return s;
}

constexpr EnumName<BenchOutcome> kOutcomeNames[] = {{BenchOutcome::kSolved, "solved"},
                                                    {BenchOutcome::kSolveFailed, "solve-failed"},
                                                    {BenchOutcome::kBadInput, "bad-input"},
                                                    {BenchOutcome::kCrashed, "crashed"}};

}  // namespace

const char* OutcomeName(BenchOutcome o) { return NameOf(kOutcomeNames, o, "crashed"); }

bool OutcomeFromName(const std::string& s, BenchOutcome* o) { return ValueOf(kOutcomeNames, s, o); }

int Severity(BenchOutcome o) {
  switch (o) {
    case BenchOutcome::kSolved:
      return 0;
    case BenchOutcome::kSolveFailed:
      return 1;
    case BenchOutcome::kBadInput:
      return 2;
    case BenchOutcome::kCrashed:
      return 3;
  }
  return 3;
}

int ExitCode(const std::vector<BenchOutcome>& outcomes) {
  int worst = 0;
  bool bad_input = false;
  for (BenchOutcome o : outcomes) {
    worst = std::max(worst, Severity(o));
    bad_input = bad_input || o == BenchOutcome::kBadInput;
  }
  if (worst == Severity(BenchOutcome::kSolved)) return 0;
  return bad_input ? 1 : 3;
}

bool ChildResult::exited_cleanly() const {
  return error.empty() && WIFEXITED(wait_status) && WEXITSTATUS(wait_status) == 0;
}

std::string ChildResult::Failure(bool complete) const {
  if (!error.empty()) return error;
  if (WIFSIGNALED(wait_status)) {
    const int sig = WTERMSIG(wait_status);
    return "killed by signal " + std::to_string(sig) + " (" + ::strsignal(sig) + ")";
  }
  if (!complete) return "the run ended (exit code " + std::to_string(WEXITSTATUS(wait_status)) + ") without reporting";
  return "";
}

ChildResult RunInChild(const std::function<std::string()>& body) {
  ChildResult c;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) {
    c.error = std::string("cannot create a pipe: ") + std::strerror(errno);
    return c;
  }
  std::fflush(nullptr);  // nothing buffered may be written twice
  const pid_t pid = ::fork();
  if (pid < 0) {
    c.error = std::string("cannot fork: ") + std::strerror(errno);
    ::close(fds[0]);
    ::close(fds[1]);
    return c;
  }
  if (pid == 0) {
    ::close(fds[0]);
    std::string report;
    try {
      report = body();
    } catch (...) {
      report.clear();
    }
    WriteAll(fds[1], report);
    ::close(fds[1]);
    ::_exit(0);  // no atexit handlers, no flushing of the parent's buffers
  }
  ::close(fds[1]);
  c.report = ReadAllFd(fds[0]);
  ::close(fds[0]);
  struct rusage usage;
  std::memset(&usage, 0, sizeof(usage));
  while (::wait4(pid, &c.wait_status, 0, &usage) < 0 && errno == EINTR) {
  }
  c.peak_rss_mib = static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB
  return c;
}

bool ParseReport(const std::string& text, std::map<std::string, std::string>* fields) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line == "end") return true;
    const std::size_t sp = line.find(' ');
    (*fields)[line.substr(0, sp)] = sp == std::string::npos ? "" : line.substr(sp + 1);
  }
  return false;
}

std::string OneLine(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  return s;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + "\"";
}

std::string Basename(const std::string& path) { return fs::path(path).filename().string(); }

std::string CheckFilesAndOutput(const std::vector<std::string>& files, const std::string& output) {
  for (const std::string& f : files) {
    std::error_code ec;
    if (!fs::exists(f, ec)) return "no such file: " + f;
    if (fs::is_directory(f, ec)) return f + " is a directory; name graph files";
  }
  if (!output.empty()) {
    // The same checks every output of tether gets (output_file.h): up front, before any run.
    OutputSet outputs;
    for (const std::string& f : files) outputs.AddInput(f, "graph file");
    try {
      outputs.Add(output, "table");
    } catch (const Error& e) {
      return e.what();
    }
  }
  return "";
}

int WriteTable(const std::string& table, const std::string& output, std::ostream& out, std::ostream& err) {
  if (output.empty()) {
    out << table << std::flush;
    return 0;
  }
  try {
    WriteTextFile(output, table, "table");
  } catch (const Error& e) {
    err << "error: " << e.what() << "\n";
    return 4;
  }
  err << "wrote " << output << "\n";
  return 0;
}

}  // namespace bench
}  // namespace tether
