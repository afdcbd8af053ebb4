// Outputs never destroy data (doc/reliability.md): what an AtomicOutput may replace, the inputs and the
// all-or-none commit of an OutputSet, the removal of temporaries when a signal ends the process, and the
// verified reading of gzip files.
#include <gtest/gtest.h>

#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <mrpt/io/CFileGZInputStream.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/GzipStream.h"

#include "pslam_test/TestSupport.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

/// A fresh folder for one test in this process's temporary folder (removed when the process ends; the forked
/// children leave with _exit and do not remove it).
fs::path tempDir(const std::string& name) {
  static const test_support::TempDir root("pslam_test_outputs");
  return test_support::freshSubDir(root, name);
}

std::string readAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// Everything a GzipInputStream reads from `p`, in pieces smaller than a block; expects the verified end.
std::string readGzipThrough(const fs::path& p) {
  GzipInputStream in(p);
  std::string out;
  char buf[1000];
  std::size_t n = 0;
  while ((n = in.Read(buf, sizeof buf)) > 0) out.append(buf, n);
  EXPECT_TRUE(in.atEnd());
  return out;
}

template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::size_t temporariesIn(const fs::path& dir) {
  std::size_t n = 0;
  for (const auto& e : fs::directory_iterator(dir)) n += e.path().filename().string().find(".tmp-") != std::string::npos;
  return n;
}

const OutputKind kFrames = OutputKind::folder("frame_[0-9]{3}\\.png");

}  // namespace

TEST(OutputKind, FolderReplacesOnlyAnEarlierOutputOfItsKind) {
  const fs::path d = tempDir("folder_kind");
  auto writeFrames = [&](int n) {
    AtomicOutput out(d / "frames", kFrames);
    ASSERT_TRUE(fs::is_directory(out.tempPath()));  // reserved by the constructor
    for (int i = 0; i < n; ++i) std::ofstream(out.tempPath() / ("frame_00" + std::to_string(i) + ".png")) << i;
    out.commit();
  };
  writeFrames(3);
  writeFrames(2);  // the earlier output of the same kind is replaced
  EXPECT_FALSE(fs::exists(d / "frames" / "frame_002.png"));
  EXPECT_TRUE(fs::exists(d / "frames" / "frame_001.png"));

  std::ofstream(d / "frames" / "notes.txt") << "mine";
  const std::string foreign = errorOf([&] { writeFrames(1); });
  EXPECT_NE(foreign.find("frames: holds 'notes.txt', which is not an output of this kind; refusing to replace the folder"),
            std::string::npos)
      << foreign;
  EXPECT_EQ(readAll(d / "frames" / "notes.txt"), "mine");

  std::ofstream(d / "file") << "x";
  EXPECT_NE(errorOf([&] { AtomicOutput out(d / "file", kFrames); }).find("file: is a file; refusing to replace it"),
            std::string::npos);
  fs::create_directories(d / "real");
  fs::create_directory_symlink(d / "real", d / "link");
  EXPECT_NE(errorOf([&] { AtomicOutput out(d / "link", kFrames); }).find("is a symbolic link"), std::string::npos);
  fs::create_directories(d / "empty");
  EXPECT_NO_THROW({
    AtomicOutput out(d / "empty/", kFrames);  // a trailing separator names the folder itself
    out.commit();
  });
  EXPECT_EQ(temporariesIn(d), 0u);
}

TEST(OutputKind, FileNeverReplacesAFolderOrASpecialFile) {
  const fs::path d = tempDir("file_kind");
  std::ofstream(d / "old.txt") << "old";
  writeFileAtomically(d / "old.txt", [](std::ostream& os) { os << "new"; });
  EXPECT_EQ(readAll(d / "old.txt"), "new");
  ASSERT_EQ(::mkfifo((d / "pipe").c_str(), 0600), 0);
  EXPECT_NE(errorOf([&] { writeFileAtomically(d / "pipe", [](std::ostream&) {}); }).find("pipe: is not a regular file"),
            std::string::npos);
  fs::create_directories(d / "dir");
  fs::create_directory_symlink(d / "dir", d / "dirlink");
  EXPECT_NE(errorOf([&] { writeFileAtomically(d / "dirlink", [](std::ostream&) {}); }).find("is a folder"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { AtomicOutput out(d / "."); }).find("not a valid output path"), std::string::npos);
  // A path below a regular file fails in the constructor, before any work.
  EXPECT_NE(errorOf([&] { AtomicOutput out(d / "old.txt" / "x.json"); }).find("old.txt: cannot create output folder"),
            std::string::npos);
  EXPECT_EQ(temporariesIn(d), 0u);
}

TEST(OutputSet, RefusesInputsWhateverTheSpelling) {
  const fs::path d = tempDir("inputs");
  fs::create_directories(d / "sub");
  std::ofstream(d / "in.txt") << "input";
  fs::create_symlink(d / "in.txt", d / "alias.txt");
  fs::create_hard_link(d / "in.txt", d / "hard.txt");
  OutputSet set({d / "in.txt"});
  for (const fs::path& p : {d / "in.txt", d / "sub" / ".." / "in.txt", d / "alias.txt", d / "hard.txt"}) {
    SCOPED_TRACE(p.string());
    EXPECT_NE(errorOf([&] { set.add(p); }).find("is the input " + (d / "in.txt").string()), std::string::npos)
        << errorOf([&] { set.add(p); });
  }
  // A folder output may not hold an input.
  EXPECT_NE(errorOf([&] { set.add(d, kFrames); }).find("holds the input"), std::string::npos);
  set.add(d / "out.txt");
  EXPECT_NE(errorOf([&] { set.add(d / "sub" / ".." / "out.txt"); }).find("given as two outputs"), std::string::npos);
  EXPECT_EQ(readAll(d / "in.txt"), "input");
}

TEST(OutputSet, CommitsAllOrNone) {
  const fs::path d = tempDir("all_or_none");
  {
    OutputSet set;
    AtomicOutput& a = set.add(d / "a.txt");
    writeOutputFile(a, [](std::ostream& os) { os << "a"; });
    // The second output is impossible: the set fails while it is being prepared, before anything is committed.
    std::ofstream(d / "file") << "x";
    EXPECT_THROW(set.add(d / "file" / "b.txt"), Error);
  }
  EXPECT_FALSE(fs::exists(d / "a.txt"));
  {
    OutputSet set;
    AtomicOutput& a = set.add(d / "a.txt");
    AtomicOutput& b = set.add(d / "b.txt");
    writeOutputFile(a, [](std::ostream& os) { os << "a"; });
    writeOutputFile(b, [](std::ostream& os) { os << "b"; });
    fs::create_directories(d / "b.txt" / "keep");  // appears while the run works
    EXPECT_NE(errorOf([&] { set.commit(); }).find("b.txt: is a folder"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(d / "a.txt"));
  EXPECT_TRUE(fs::is_directory(d / "b.txt" / "keep"));
  EXPECT_EQ(temporariesIn(d), 0u);
}

namespace {
/// Runs this test program again, fresh (no handler installed yet), as the child of the signal tests: it makes
/// outputs in `dir` and raises `sig` (AtomicOutput.SignalChild). `ignored`: the child starts with `sig` ignored.
int runSignalChild(const fs::path& dir, int sig, bool ignored) {
  const std::string exe = fs::read_symlink("/proc/self/exe").string();
  const std::string env = "PSLAM_SIGNAL_CHILD=" + std::to_string(sig) + ":" + dir.string();
  const pid_t pid = ::fork();
  if (pid == 0) {
    for (int s : {SIGINT, SIGTERM, SIGHUP}) ::signal(s, SIG_DFL);
    if (ignored) ::signal(sig, SIG_IGN);
    ::putenv(const_cast<char*>(env.c_str()));
    ::execl(exe.c_str(), exe.c_str(), "--gtest_filter=AtomicOutput.SignalChild", static_cast<char*>(nullptr));
    ::_exit(127);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}
}  // namespace

// The temporaries of live outputs are removed when a signal ends the process, which still ends by that signal;
// a signal the process ignores stays ignored.
TEST(AtomicOutput, SignalRemovesLiveTemporaries) {
  const fs::path d = tempDir("signal");
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    SCOPED_TRACE(sig);
    const int status = runSignalChild(d, sig, false);
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << status;
    EXPECT_EQ(temporariesIn(d), 0u);
    EXPECT_FALSE(fs::exists(d / "out.bin"));
  }
  const int status = runSignalChild(d, SIGINT, true);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  EXPECT_EQ(temporariesIn(d), 0u);
}

// The child of SignalRemovesLiveTemporaries (skipped when run on its own).
TEST(AtomicOutput, SignalChild) {
  const char* spec = std::getenv("PSLAM_SIGNAL_CHILD");
  if (!spec) GTEST_SKIP() << "the child process of AtomicOutput.SignalRemovesLiveTemporaries";
  const std::string s = spec;
  const int sig = std::stoi(s.substr(0, s.find(':')));
  const fs::path d = s.substr(s.find(':') + 1);
  AtomicOutput file(d / "out.bin");
  std::ofstream(file.tempPath()) << "partial";
  AtomicOutput folder(d / "frames", kFrames);
  for (int i = 0; i < 50; ++i) std::ofstream(folder.tempPath() / ("frame_0" + std::to_string(10 + i) + ".png")) << i;
  ::raise(sig);  // ends the process unless the signal is ignored
}

TEST(GzipInputStream, VerifiesTheStreamToItsEnd) {
  const fs::path d = tempDir("gzip");
  std::string payload;
  for (int i = 0; i < 20000; ++i) payload += std::to_string(i * 7919 % 10007) + ",";
  {
    mrpt::io::CFileGZOutputStream out((d / "ok.gz").string());
    out.Write(payload.data(), payload.size());
  }
  EXPECT_EQ(readGzipThrough(d / "ok.gz"), payload);
  const std::string gz = readAll(d / "ok.gz");

  std::string crc = gz;
  crc[crc.size() - 6] = static_cast<char>(crc[crc.size() - 6] ^ 0x10);  // CRC-32 of the trailer
  std::ofstream(d / "crc.gz", std::ios::binary) << crc;
  const std::string crcError = errorOf([&] { readGzipThrough(d / "crc.gz"); });
  EXPECT_NE(crcError.find("crc.gz: corrupt gzip data (zlib: incorrect data check, found at compressed byte"), std::string::npos) << crcError;
  EXPECT_NE(crcError.find("incorrect data check"), std::string::npos) << crcError;

  std::string length = gz;
  length[length.size() - 2] = static_cast<char>(length[length.size() - 2] ^ 0x01);  // ISIZE of the trailer
  std::ofstream(d / "length.gz", std::ios::binary) << length;
  EXPECT_NE(errorOf([&] { readGzipThrough(d / "length.gz"); }).find("incorrect length check"), std::string::npos);

  std::ofstream(d / "cut.gz", std::ios::binary) << gz.substr(0, gz.size() / 2);
  EXPECT_NE(errorOf([&] { readGzipThrough(d / "cut.gz"); }).find("cut.gz: truncated"), std::string::npos);

  std::ofstream(d / "plain.txt", std::ios::binary) << "plain text";
  {
    GzipInputStream plain(d / "plain.txt");
    EXPECT_FALSE(plain.compressed());
    char buf[5];
    ASSERT_EQ(plain.Read(buf, 5), 5u);
    EXPECT_NE(errorOf([&] { plain.requireEnd(); }).find("unexpected data"), std::string::npos);
  }
  EXPECT_NE(errorOf([&] { GzipInputStream missing(d / "missing.gz"); }).find("missing.gz: file not found"),
            std::string::npos);
}

// Reliability (doc/reliability.md): verifyGzipFile finds what reading finds (a CRC-32 or length mismatch, a cut
// file), gives the length of the data, and refuses bytes after the last gzip member (which zlib's reader ignores:
// a file appended to was accepted). Several members are one stream.
TEST(GzipInputStream, VerificationRefusesBytesAfterTheStream) {
  const fs::path d = tempDir("gzip_verify");
  std::string payload;
  for (int i = 0; i < 30000; ++i) payload += std::to_string(i * 7919 % 10007) + ",";
  {
    mrpt::io::CFileGZOutputStream out((d / "ok.gz").string());
    out.Write(payload.data(), payload.size());
  }
  const std::string gz = readAll(d / "ok.gz");
  EXPECT_EQ(verifyGzipFile(d / "ok.gz"), payload.size());
  std::ofstream(d / "two.gz", std::ios::binary) << gz + gz;
  EXPECT_EQ(verifyGzipFile(d / "two.gz"), 2 * payload.size());
  std::ofstream(d / "plain.txt", std::ios::binary) << "plain text";
  EXPECT_EQ(verifyGzipFile(d / "plain.txt"), 10u);
  std::ofstream(d / "appended.gz", std::ios::binary) << gz + "appended text";
  EXPECT_NE(errorOf([&] { verifyGzipFile(d / "appended.gz"); })
                .find("appended.gz: 13 bytes after the end of the gzip data (at byte " + std::to_string(gz.size())),
            std::string::npos);
  std::ofstream(d / "zeros.gz", std::ios::binary) << gz + std::string(512, '\0');
  EXPECT_NE(errorOf([&] { verifyGzipFile(d / "zeros.gz"); }).find("512 bytes after the end of the gzip data"),
            std::string::npos);
  std::string crc = gz;
  crc[crc.size() - 6] = static_cast<char>(crc[crc.size() - 6] ^ 0x10);
  std::ofstream(d / "crc.gz", std::ios::binary) << crc;
  EXPECT_NE(errorOf([&] { verifyGzipFile(d / "crc.gz"); })
                .find("crc.gz: corrupt gzip data (zlib: incorrect data check, found at compressed byte"),
            std::string::npos);
  std::ofstream(d / "cut.gz", std::ios::binary) << gz.substr(0, gz.size() / 2);
  EXPECT_NE(errorOf([&] { verifyGzipFile(d / "cut.gz"); }).find("cut.gz: truncated: the gzip data ends at byte"),
            std::string::npos);
}

TEST(GzipOutputStream, BlocksReadAsOneStreamAndTheBytesDependOnTheDataOnly) {
  const fs::path d = tempDir("gzip_write");
  std::string payload;  // compressible text and bytes that hardly compress, as a map's descriptors
  for (int i = 0; i < 30000; ++i) payload += std::to_string(i * 7919 % 10007) + ",";
  for (int i = 0; i < 100000; ++i) payload += static_cast<char>((i * 2654435761u) >> 24);
  // Written in pieces of `piece` bytes (0: in one call).
  auto write = [&](const fs::path& p, int level, std::size_t block, unsigned threads, std::size_t piece) {
    GzipOutputStream out(p, level, block, threads);
    for (std::size_t at = 0; at < payload.size(); at += piece ? piece : payload.size())
      out.Write(payload.data() + at, std::min(payload.size() - at, piece ? piece : payload.size()));
    EXPECT_EQ(out.getPosition(), payload.size());
    out.close();
  };
  for (const std::size_t block : {std::size_t(1) << 20, payload.size(), std::size_t(50000), std::size_t(777)}) {
    SCOPED_TRACE(block);
    write(d / "one_thread.gz", 1, block, 1, 0);
    const std::string reference = readAll(d / "one_thread.gz");
    EXPECT_EQ(readGzipThrough(d / "one_thread.gz"), payload);
    EXPECT_NO_THROW(verifyGzipFile(d / "one_thread.gz"));
    for (const unsigned threads : {2u, 3u}) {
      for (const std::size_t piece : {std::size_t(0), std::size_t(1000), std::size_t(65537)}) {
        write(d / "other.gz", 1, block, threads, piece);
        EXPECT_EQ(readAll(d / "other.gz"), reference) << threads << " threads, pieces of " << piece;
      }
    }
    // MRPT's reader (gzread) reads the members as one stream too.
    mrpt::io::CFileGZInputStream mrptIn((d / "one_thread.gz").string());
    std::string viaMrpt(payload.size() + 1, '\0');
    EXPECT_EQ(mrptIn.Read(viaMrpt.data(), viaMrpt.size()), payload.size());
    EXPECT_EQ(viaMrpt.substr(0, payload.size()), payload);
  }
  // The first member of a file of several is what a file of that first block alone would be: a file cut there
  // ends at a verified gzip trailer, so a reader of the content has to notice what is missing
  // (MapIO.CutBetweenGzipMembers).
  const std::size_t block = 50000;
  write(d / "blocks.gz", 6, block, 2, 0);
  {
    GzipOutputStream first(d / "first.gz", 6, block, 2);
    first.Write(payload.data(), block);
    first.close();
  }
  const std::string blocks = readAll(d / "blocks.gz"), first = readAll(d / "first.gz");
  ASSERT_LT(first.size(), blocks.size());
  EXPECT_EQ(blocks.substr(0, first.size()), first);
  EXPECT_EQ(readGzipThrough(d / "first.gz"), payload.substr(0, block));
  // Level 0 stores; nothing written is a valid empty file; a close without writes or twice is harmless.
  write(d / "stored.gz", 0, 1 << 20, 2, 0);
  EXPECT_GT(fs::file_size(d / "stored.gz"), payload.size());
  EXPECT_EQ(readGzipThrough(d / "stored.gz"), payload);
  {
    GzipOutputStream empty(d / "empty.gz", 6);
    empty.close();
    empty.close();
    EXPECT_NE(errorOf([&] { empty.Write("a", 1); }).find("empty.gz: written after it was closed"), std::string::npos);
  }
  EXPECT_EQ(readGzipThrough(d / "empty.gz"), "");
  EXPECT_NE(errorOf([&] { GzipOutputStream s(d / "x.gz", 10); }).find("x.gz: gzip level 10 is not in 0-9"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { GzipOutputStream s(d / "x.gz", 1, 0); }).find("x.gz: gzip blocks of 0 bytes"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { GzipOutputStream s(d / "x.gz", 1, 10, 0); }).find("x.gz: gzip compression on 0 threads"),
            std::string::npos);
  EXPECT_NE(errorOf([&] { GzipOutputStream s(d / "missing" / "x.gz", 1); }).find("x.gz: cannot open for writing"),
            std::string::npos);
}

TEST(Error, OneLineMessageOfAnMrptReport) {
  const std::string mrpt =
      "==== MRPT exception ====\nMessage:  Value 'fx' not found in section 'CAMERA'\nLocation: a.cpp:1: [f]\n"
      "Call stack backtrace:\n[0] 0x1\n";
  EXPECT_EQ(oneLineMessage(mrpt), "Value 'fx' not found in section 'CAMERA'");
  EXPECT_EQ(oneLineMessage(std::string("\nfirst line\nsecond")), "first line");
  EXPECT_EQ(oneLineMessage(Error("x.txt: bad")), "x.txt: bad");
}

// Reliability (doc/reliability.md): after kill -9 of a tool, its temporaries stayed forever; the next output to the
// same place removes those of processes that no longer exist, and only those.
TEST(AtomicOutput, StaleTemporariesOfDeadProcessesAreRemoved) {
  const fs::path d = tempDir("stale");
  const pid_t dead = ::fork();
  if (dead == 0) ::_exit(0);
  int st = 0;
  ::waitpid(dead, &st, 0);
  const std::string deadSuffix = ".tmp-" + std::to_string(dead) + "-0";
  std::ofstream(d / ("trajectory.txt" + deadSuffix)) << "partial";
  fs::create_directories(d / ("frames" + deadSuffix));
  std::ofstream(d / ("frames" + deadSuffix) / "frame_010.png") << "x";
  const std::string liveSuffix = ".tmp-" + std::to_string(::getppid()) + "-0";  // our parent: alive
  std::ofstream(d / ("trajectory.txt" + liveSuffix)) << "another run's";
  std::ofstream(d / "trajectory.txt.tmp-notes") << "not a temporary of ours";
  {
    AtomicOutput out(d / "trajectory.txt");
    std::ofstream(out.tempPath()) << "new";
    out.commit();
  }
  EXPECT_FALSE(fs::exists(d / ("trajectory.txt" + deadSuffix)));
  EXPECT_TRUE(fs::exists(d / ("trajectory.txt" + liveSuffix)));
  EXPECT_TRUE(fs::exists(d / "trajectory.txt.tmp-notes"));
  EXPECT_TRUE(fs::exists(d / ("frames" + deadSuffix)));  // another output's: removed by the next one of its own
  { AtomicOutput frames(d / "frames", kFrames); }
  EXPECT_FALSE(fs::exists(d / ("frames" + deadSuffix)));
}
