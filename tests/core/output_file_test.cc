// The one output writer (tether/core/output_file.h): what each kind of path gets, staging and
// committing together, and the failures, each with a message naming the path.
#include "tether/core/output_file.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "tether/core/error.h"

namespace tether {
namespace {

namespace fs = std::filesystem;

class OutputFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/tether_output_XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return dir_ + "/" + name; }
  static std::string Read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }
  static void Put(const std::string& path, const std::string& text) { std::ofstream(path) << text; }
  // Every name in the folder: nothing but the outputs may be left.
  std::vector<std::string> Names() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  template <class F>
  static std::string MessageOf(F&& f) {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  }

  std::string dir_;
};

TEST_F(OutputFileTest, NewFileIsWrittenAndNothingElseIsLeft) {
  OutputFile out(Path("a.txt"), "table");
  EXPECT_EQ(out.mode(), OutputMode::kReplace);
  EXPECT_TRUE(out.note().empty());
  EXPECT_FALSE(fs::exists(Path("a.txt")));  // nothing is created when the path is checked
  out.Stage("hello\n");
  EXPECT_FALSE(fs::exists(Path("a.txt")));  // nor when it is staged
  out.Commit();
  EXPECT_EQ(Read(Path("a.txt")), "hello\n");
  EXPECT_EQ(Names(), std::vector<std::string>{"a.txt"});
}

TEST_F(OutputFileTest, ExistingFileIsReplacedKeepingItsPermissions) {
  Put(Path("a.txt"), "old");
  ASSERT_EQ(::chmod(Path("a.txt").c_str(), 0640), 0);
  WriteTextFile(Path("a.txt"), "new", "table");
  EXPECT_EQ(Read(Path("a.txt")), "new");
  struct stat st;
  ASSERT_EQ(::stat(Path("a.txt").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  EXPECT_EQ(Names(), std::vector<std::string>{"a.txt"});
}

TEST_F(OutputFileTest, SymbolicLinkIsFollowedAndStaysALink) {
  Put(Path("real.txt"), "old");
  fs::create_symlink("real.txt", Path("link.txt"));
  OutputFile out(Path("link.txt"), "table");
  EXPECT_EQ(out.target(), dir_ + "/real.txt");
  out.Stage("new");
  out.Commit();
  EXPECT_TRUE(fs::is_symlink(Path("link.txt")));
  EXPECT_EQ(Read(Path("real.txt")), "new");
  // A dangling link: its target is created.
  fs::create_symlink("made.txt", Path("dangling.txt"));
  WriteTextFile(Path("dangling.txt"), "made", "table");
  EXPECT_TRUE(fs::is_symlink(Path("dangling.txt")));
  EXPECT_EQ(Read(Path("made.txt")), "made");
}

TEST_F(OutputFileTest, CharacterDeviceIsWrittenInPlaceNotReplaced) {
  OutputFile out("/dev/null", "optimised graph");
  EXPECT_EQ(out.mode(), OutputMode::kInPlace);
  EXPECT_TRUE(out.char_device());
  EXPECT_NE(out.note().find("/dev/null is a character device"), std::string::npos) << out.note();
  EXPECT_NE(out.note().find("in place"), std::string::npos) << out.note();
  out.Stage("discarded\n");
  out.Commit();
  struct stat st;
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

TEST_F(OutputFileTest, DeviceThatIsFullGivesAnErrorNamingIt) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  OutputFile out("/dev/full", "optimised graph");
  out.Stage("x\n");
  const std::string m = MessageOf([&] { out.Commit(); });
  EXPECT_NE(m.find("'/dev/full'"), std::string::npos) << m;
  EXPECT_NE(m.find("disk is full"), std::string::npos) << m;
}

TEST_F(OutputFileTest, FifoIsWrittenInPlaceToItsReader) {
  ASSERT_EQ(::mkfifo(Path("f").c_str(), 0600), 0);
  OutputFile out(Path("f"), "plot");
  EXPECT_EQ(out.mode(), OutputMode::kInPlace);
  EXPECT_NE(out.note().find("FIFO"), std::string::npos);
  out.Stage("through the pipe\n");
  // Without a reader the commit fails at once (no hang) and says what to do.
  const std::string m = MessageOf([&] { out.Commit(); });
  EXPECT_NE(m.find("nothing is reading the FIFO"), std::string::npos) << m;
  EXPECT_FALSE(out.committed());

  OutputFile again(Path("f"), "plot");
  again.Stage("through the pipe\n");
  std::string got;
  std::thread reader([&] { got = Read(Path("f")); });
  // The reader opens the FIFO; retry until it has.
  for (int i = 0; i < 500 && !again.committed(); ++i) {
    try {
      again.Commit();
    } catch (const IoError&) {
      again.Stage("through the pipe\n");
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  reader.join();
  EXPECT_TRUE(again.committed());
  EXPECT_EQ(got, "through the pipe\n");
  EXPECT_TRUE(fs::is_fifo(Path("f")));
}

TEST_F(OutputFileTest, DescriptorPathsWriteToTheDescriptor) {
  int p[2];
  ASSERT_EQ(::pipe(p), 0);
  {
    OutputFile out("/dev/fd/" + std::to_string(p[1]), "table");
    EXPECT_EQ(out.mode(), OutputMode::kDescriptor);
    EXPECT_NE(out.note().find("descriptor " + std::to_string(p[1])), std::string::npos);
    out.Stage("to the descriptor");
    out.Commit();
  }
  ::close(p[1]);
  char buf[64] = {};
  const ssize_t n = ::read(p[0], buf, sizeof buf - 1);
  ::close(p[0]);
  EXPECT_EQ(std::string(buf, n > 0 ? static_cast<std::size_t>(n) : 0), "to the descriptor");
  EXPECT_EQ(OutputFile("/dev/stdout", "x").mode(), OutputMode::kDescriptor);
  EXPECT_EQ(OutputFile("/proc/self/fd/2", "x").mode(), OutputMode::kDescriptor);
}

TEST_F(OutputFileTest, PathsThatCannotBeWrittenAreRefusedUpFrontNamingThem) {
  EXPECT_THROW(OutputFile("", "optimised graph"), InvalidArgument);
  const std::string empty = MessageOf([] { OutputFile("", "optimised graph"); });
  EXPECT_NE(empty.find("empty"), std::string::npos) << empty;

  const std::string folder = MessageOf([&] { OutputFile(dir_, "plot"); });
  EXPECT_NE(folder.find("'" + dir_ + "'"), std::string::npos) << folder;
  EXPECT_NE(folder.find("is a folder"), std::string::npos) << folder;

  const std::string missing = MessageOf([&] { OutputFile(Path("no/such/out.g2o"), "plot"); });
  EXPECT_NE(missing.find("does not exist"), std::string::npos) << missing;

  const std::string proc = MessageOf([] { OutputFile("/proc/self/status", "plot"); });
  EXPECT_NE(proc.find("under /proc"), std::string::npos) << proc;
  const std::string sys = MessageOf([] { OutputFile("/sys/kernel/tether_out", "plot"); });
  EXPECT_NE(sys.find("under /sys"), std::string::npos) << sys;

  const std::string closed = MessageOf([] { OutputFile("/dev/fd/987", "plot"); });
  EXPECT_NE(closed.find("not open for writing"), std::string::npos) << closed;
  EXPECT_TRUE(Names().empty());
}

TEST_F(OutputFileTest, BlockDevicesAndSocketsAreRefused) {
  std::string block;
  for (const auto& e : fs::directory_iterator("/dev")) {
    std::error_code ec;
    if (fs::is_block_file(e.path(), ec)) {
      block = e.path();
      break;
    }
  }
  if (block.empty()) GTEST_SKIP() << "no block device in /dev here";
  const std::string m = MessageOf([&] { OutputFile(block, "plot"); });
  EXPECT_NE(m.find("block device"), std::string::npos) << m;
}

TEST_F(OutputFileTest, AFailedStageLeavesTheTargetAndNoTemporaryFile) {
  Put(Path("a.txt"), "old");
  OutputFile out(Path("a.txt"), "table");
  EXPECT_THROW(out.Stage([](std::ostream& s) {
    s << "half";
    throw std::runtime_error("the writer failed");
  }),
               std::runtime_error);
  EXPECT_FALSE(out.staged());
  EXPECT_EQ(Read(Path("a.txt")), "old");
  EXPECT_EQ(Names(), std::vector<std::string>{"a.txt"});
  // Staged and dropped: the same.
  out.Stage("new");
  out.Discard();
  EXPECT_EQ(Read(Path("a.txt")), "old");
  EXPECT_EQ(Names(), std::vector<std::string>{"a.txt"});
  {
    OutputFile dropped(Path("b.txt"), "table");
    dropped.Stage("never committed");
  }
  EXPECT_EQ(Names(), std::vector<std::string>{"a.txt"});
}

TEST_F(OutputFileTest, OutputsMayNotNameAnInputOrEachOther) {
  Put(Path("in.g2o"), "graph");
  fs::create_symlink("in.g2o", Path("alias.g2o"));
  fs::create_hard_link(Path("in.g2o"), Path("hard.g2o"));
  OutputSet set;
  set.AddInput(Path("in.g2o"), "input graph");
  for (const char* name : {"in.g2o", "alias.g2o", "hard.g2o"}) {
    const std::string m = MessageOf([&] { set.Add(Path(name), "plot"); });
    EXPECT_NE(m.find("does not write over what it reads"), std::string::npos) << name << ": " << m;
  }
  set.Add(Path("out.g2o"), "optimised graph");
  const std::string twice = MessageOf([&] { set.Add(dir_ + "/./out.g2o", "plot"); });
  EXPECT_NE(twice.find("both name"), std::string::npos) << twice;
  // A character device may take two outputs.
  set.Add("/dev/null", "plot");
  EXPECT_NO_THROW(set.Add("/dev/null", "covariances"));
  EXPECT_EQ(Read(Path("in.g2o")), "graph");
}

TEST_F(OutputFileTest, CommitAllCommitsTogetherOrNothing) {
  Put(Path("a.txt"), "old a");
  {
    OutputSet set;
    OutputFile& a = set.Add(Path("a.txt"), "graph");
    OutputFile& b = set.Add(Path("b.txt"), "plot");
    a.Stage("new a");
    b.Stage("new b");
    set.CommitAll();
    EXPECT_EQ(Read(Path("a.txt")), "new a");
    EXPECT_EQ(Read(Path("b.txt")), "new b");
  }
  // A FIFO without a reader fails before any file is renamed: nothing changes.
  ASSERT_EQ(::mkfifo(Path("f").c_str(), 0600), 0);
  OutputSet set;
  OutputFile& a = set.Add(Path("a.txt"), "graph");
  OutputFile& f = set.Add(Path("f"), "plot");
  a.Stage("newer a");
  f.Stage("svg");
  EXPECT_THROW(set.CommitAll(), IoError);
  EXPECT_EQ(Read(Path("a.txt")), "new a");
  EXPECT_FALSE(a.staged());
  EXPECT_EQ(Names(), (std::vector<std::string>{"a.txt", "b.txt", "f"}));
}

// Under a file-size limit the write fails with a message naming the file (SIGXFSZ ignored, as
// the tether program does), and no temporary file is left.
TEST_F(OutputFileTest, FileSizeLimitIsAnErrorNamingTheFile) {
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    struct rlimit limit = {4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    try {
      WriteTextFile(Path("big.txt"), std::string(1 << 20, 'x'), "optimised graph");
    } catch (const IoError& e) {
      const std::string m = e.what();
      const bool named = m.find("big.txt") != std::string::npos && m.find("file-size limit") != std::string::npos;
      std::_Exit(named ? 0 : 2);
    }
    std::_Exit(1);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "1: no error, 2: the message did not name the file and the limit";
  EXPECT_TRUE(Names().empty());
}

// A failure after some files were renamed (here the device written last) puts every old file
// back and removes the new file that had no old one; the message says so.
TEST_F(OutputFileTest, AFailureAfterTheRenamesPutsTheOldSetBack) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full here";
  Put(Path("a.txt"), "old a");
  Put(Path("c.txt"), "old c");
  OutputSet set;
  OutputFile& a = set.Add(Path("a.txt"), "graph");
  OutputFile& b = set.Add(Path("b.txt"), "plot");
  OutputFile& c = set.Add(Path("c.txt"), "table");
  OutputFile& full = set.Add("/dev/full", "log");
  a.Stage("new a");
  b.Stage("new b");
  c.Stage("new c");
  full.Stage("anything");
  const std::string message = MessageOf([&] { set.CommitAll(); });
  EXPECT_NE(message.find("/dev/full"), std::string::npos) << message;
  EXPECT_NE(message.find("every replaced file was put back as it was"), std::string::npos) << message;
  EXPECT_EQ(Read(Path("a.txt")), "old a");
  EXPECT_EQ(Read(Path("c.txt")), "old c");
  EXPECT_EQ(Names(), (std::vector<std::string>{"a.txt", "c.txt"}));  // no b.txt, journal or copy
}

// Killed part-way through the renames, a set is mixed on disk; the next OutputSet that writes
// into that folder puts the old set back. Killed after the commit point, the new set stands
// and only the old copies go.
TEST_F(OutputFileTest, AKilledCommitIsUndoneOrFinishedByTheNextRun) {
  for (int kill_after : {0, 1, 2, 3}) {
    SCOPED_TRACE("killed before rename " + std::to_string(kill_after));
    fs::remove_all(dir_);
    fs::create_directory(dir_);
    Put(Path("a.txt"), "old a");
    Put(Path("b.txt"), "old b");
    const pid_t pid = ::fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      ::setenv("TETHER_TEST_KILL_AFTER_RENAMES", std::to_string(kill_after).c_str(), 1);
      OutputSet set;
      set.Add(Path("a.txt"), "graph").Stage("new a");
      set.Add(Path("b.txt"), "plot").Stage("new b");
      set.Add(Path("c.txt"), "table").Stage("new c");
      set.CommitAll();
      std::_Exit(0);
    }
    int status = 0;
    ASSERT_EQ(::waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) << status;
    // The journal is there, and (killed mid-way) the folder is mixed.
    const std::vector<std::string> left = Names();
    EXPECT_TRUE(
        std::any_of(left.begin(), left.end(), [](const std::string& n) { return n.rfind(".tether-commit-", 0) == 0; }));
    if (kill_after == 1) {
      EXPECT_EQ(Read(Path("a.txt")), "new a");
    }

    OutputSet next;
    next.Add(Path("other.txt"), "another output");
    const std::vector<std::string> notes = next.Notes();
    ASSERT_EQ(notes.size(), 1u);
    if (kill_after < 3) {
      EXPECT_NE(notes[0].find("the old files were put back"), std::string::npos) << notes[0];
      EXPECT_EQ(Read(Path("a.txt")), "old a");
      EXPECT_EQ(Read(Path("b.txt")), "old b");
      EXPECT_EQ(Names(), (std::vector<std::string>{"a.txt", "b.txt"}));
    } else {
      EXPECT_NE(notes[0].find("its new files stand"), std::string::npos) << notes[0];
      EXPECT_EQ(Read(Path("a.txt")), "new a");
      EXPECT_EQ(Read(Path("b.txt")), "new b");
      EXPECT_EQ(Read(Path("c.txt")), "new c");
      EXPECT_EQ(Names(), (std::vector<std::string>{"a.txt", "b.txt", "c.txt"}));
    }
  }
}

// A temporary file a killed process left (no journal: killed while staging) is cleared by the
// next set that writes there; one of a running process is not.
TEST_F(OutputFileTest, TemporaryFilesOfDeadProcessesAreCleared) {
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) std::_Exit(0);
  ::waitpid(pid, nullptr, 0);  // a PID no process has now
  const std::string dead = ".a.txt.tether-" + std::to_string(pid) + "-0-00abcd";
  const std::string alive = ".a.txt.tether-" + std::to_string(::getppid()) + "-0-00abcd";
  const std::string unrelated = ".a.txt.tether-notes";
  for (const std::string& n : {dead, alive, unrelated}) Put(Path(n), "x");
  OutputSet set;
  set.Add(Path("a.txt"), "graph");
  EXPECT_EQ(Names(), (std::vector<std::string>{alive, unrelated}));
}

}  // namespace
}  // namespace tether
