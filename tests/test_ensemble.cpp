// The MPI ensemble: result file round trip and crash safety, `ringsim run`
// under mpirun with 1, 2 and 3 ranks (identical rows), kill -9 and resume,
// a graceful stop by signal, refusals, failure isolation, `aggregate`.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "analysis/ensemble_summary.hpp"
#include "ensemble/aggregate_command.hpp"
#include "ensemble/results_file.hpp"

namespace fs = std::filesystem;
using namespace ringsim;

namespace {

// A small scene whose replicates take a fraction of a second, with bonds
// and run-to-run variation (t_max, not steady state, ends them). These tests
// are about the runner (ranks, HDF5, resume, signals), not the physics: the
// welded reading keeps the replicates short and their timing steady.
const std::string kFast =
    " --set init.spheres=60 --set init.linkers=60 --set geometry.box_length=25 --set run.t_max=25"
    " --set bonding.joint=welded";

// Longer replicates (~0.3 s) for the tests that interrupt a running ensemble.
const std::string kSlow =
    " --set init.spheres=60 --set init.linkers=60 --set geometry.box_length=25 --set run.t_max=250"
    " --set bonding.joint=welded";

struct Cmd {
  int status;
  std::string out;
  std::string err;  // shell_apart only
};

Cmd shell(const std::string& cmd) {
  Cmd r{0, ""};
  FILE* f = popen((cmd + " 2>&1").c_str(), "r");
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), f)) r.out += buf.data();
  const int st = pclose(f);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

// Standard error apart from standard output. Under mpirun the ranks' two
// streams are forwarded separately, so merged (2>&1) a line of one could be
// split by the other (seen once in CI-like load: "3 of 3 replicates failed"
// cut by the table). The progress and failure lines are on stderr.
Cmd shell_apart(const std::string& cmd) {
  char name[] = "/tmp/ringsim_test_stderr_XXXXXX";
  const int fd = mkstemp(name);
  if (fd >= 0) close(fd);
  Cmd r{0, "", ""};
  FILE* f = popen((cmd + " 2>" + name).c_str(), "r");
  std::array<char, 4096> buf;
  while (fgets(buf.data(), buf.size(), f)) r.out += buf.data();
  const int st = pclose(f);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  if (FILE* e = std::fopen(name, "r")) {
    while (fgets(buf.data(), buf.size(), e)) r.err += buf.data();
    std::fclose(e);
  }
  std::remove(name);
  return r;
}

std::string binary() { return RINGSIM_BINARY; }
std::string mpirun(int np) { return "mpirun --oversubscribe -np " + std::to_string(np) + " " + binary(); }

class Ensemble : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // mpirun as root (CI) needs these; harmless otherwise. Readers may look
    // at files a running ensemble holds open.
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    setenv("HDF5_USE_FILE_LOCKING", "FALSE", 1);
    dir_ = fs::temp_directory_path() / ("ringsim_ensemble_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string path(const std::string& name) { return (dir_ / name).string(); }
  static fs::path dir_;
};
fs::path Ensemble::dir_;

int count_status(const ResultsContent& c, RecordStatus s) {
  int n = 0;
  for (const ReplicateRecord& r : c.records) n += r.status == static_cast<std::int8_t>(s);
  return n;
}

ReplicateRecord done_row(std::uint64_t id, int n_t) {
  ReplicateRecord r{};
  r.id = id;
  r.seed = 9;
  r.status = static_cast<std::int8_t>(RecordStatus::Ok);
  std::snprintf(r.termination, sizeof r.termination, "t_max");
  r.N_t = n_t;
  r.S4 = std::nan("");
  r.wall_seconds = 0.5;
  return r;
}

Provenance test_provenance(std::uint64_t R, std::int64_t L) {
  Provenance p;
  p.version = "test";
  p.scenario = "unit";
  p.config_toml = "[run]\nt_max = 1.0\n";
  p.config_hash = fnv1a_hex(p.config_toml);
  p.base_seed = 9;
  p.replicates = R;
  p.series_length = L;
  return p;
}

}  // namespace

TEST(ResultsFile, FnvMatchesPublishedVectors) {
  // FNV-1a 64 test vectors (Fowler/Noll/Vo reference: "" and "a").
  EXPECT_EQ(fnv1a_hex(""), "cbf29ce484222325");
  EXPECT_EQ(fnv1a_hex("a"), "af63dc4c8601ec8c");
}

TEST_F(Ensemble, FileRoundTripKeepsRowsSeriesAndPending) {
  const std::string f = path("roundtrip.h5");
  auto w = ResultsWriter::create(f, test_provenance(4, 3));
  w->write_rows({done_row(2, 17), done_row(0, 5)}, {1, 2, 3, 4, 5, 6});
  w->close();
  const ResultsContent c = read_results(f);
  ASSERT_EQ(c.records.size(), 4u);
  EXPECT_EQ(c.provenance.config_hash, fnv1a_hex("[run]\nt_max = 1.0\n"));
  EXPECT_EQ(c.records[2].N_t, 17);
  EXPECT_EQ(c.records[0].N_t, 5);
  EXPECT_EQ(c.records[1].status, static_cast<std::int8_t>(RecordStatus::Pending));
  EXPECT_EQ(c.records[3].id, 3u);
  EXPECT_STREQ(c.records[1].termination, "pending");
  ASSERT_EQ(c.series.size(), 12u);
  EXPECT_EQ(c.series[6], 1.0f);  // row 2 got the first series row
  EXPECT_EQ(c.series[0], 4.0f);
  EXPECT_TRUE(std::isnan(c.series[3]));  // row 1 still NaN
}

TEST_F(Ensemble, FileSurvivesKillWithoutClose) {
  const std::string f = path("killed.h5");
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    auto w = ResultsWriter::create(f, test_provenance(5, 0));
    w->write_rows({done_row(1, 11)}, {});
    w->write_rows({done_row(3, 13)}, {});
    raise(SIGKILL);  // no close, no destructor
  }
  int st = 0;
  waitpid(child, &st, 0);
  ASSERT_TRUE(WIFSIGNALED(st));
  const ResultsContent c = read_results(f);
  EXPECT_EQ(c.records[1].N_t, 11);
  EXPECT_EQ(c.records[3].N_t, 13);
  EXPECT_EQ(count_status(c, RecordStatus::Pending), 3);
}

TEST_F(Ensemble, NotAResultFileIsAClearError) {
  const std::string f = path("plain.txt");
  shell("echo hello > " + f);
  try {
    read_results(f);
    FAIL() << "expected an error";
  } catch (const ResultsFileError& e) {
    EXPECT_NE(std::string(e.what()).find("not an HDF5 file"), std::string::npos) << e.what();
  }
}

TEST_F(Ensemble, RowsIdenticalForOneTwoThreeRanksAndWithoutMpirun) {
  const std::string args = " run --replicates 7 --seed 5 --series" + kFast + " -o ";
  const Cmd solo = shell(binary() + args + path("np0.h5"));
  ASSERT_EQ(solo.status, 0) << solo.out;
  EXPECT_NE(solo.out.find("N_t"), std::string::npos) << solo.out;  // the closing table
  const ResultsContent ref = read_results(path("np0.h5"));
  EXPECT_EQ(ref.provenance.complete, 1);
  EXPECT_EQ(count_status(ref, RecordStatus::Ok), 7);
  for (int np : {1, 2, 3}) {
    const std::string f = path("np" + std::to_string(np) + ".h5");
    const Cmd c = shell(mpirun(np) + args + f);
    ASSERT_EQ(c.status, 0) << c.out;
    const ResultsContent got = read_results(f);
    EXPECT_EQ(got.provenance.ranks, np);
    SCOPED_TRACE("np = " + std::to_string(np));
    ASSERT_EQ(got.records.size(), ref.records.size());
    for (std::size_t i = 0; i < ref.records.size(); ++i) {
      ReplicateRecord x = ref.records[i], y = got.records[i];
      x.wall_seconds = y.wall_seconds = 0.0;
      EXPECT_EQ(0, std::memcmp(&x, &y, sizeof x)) << "row " << i;
    }
    ASSERT_EQ(got.series.size(), ref.series.size());
    EXPECT_EQ(0, std::memcmp(got.series.data(), ref.series.data(), ref.series.size() * sizeof(float)));
  }
  // Replicates differ from each other (distinct random streams).
  EXPECT_NE(ref.records[0].events, ref.records[1].events);
  // Each row is `ringsim replicate --seed S --replicate r`.
  const Cmd one = shell(binary() + " replicate --seed 5 --replicate 4 --json" + kFast);
  ASSERT_EQ(one.status, 0);
  EXPECT_NE(one.out.find("\"events\":" + std::to_string(ref.records[4].events)), std::string::npos) << one.out;
}

TEST_F(Ensemble, KillNineThenResumeEqualsUninterruptedRun) {
  const std::string args = " run --replicates 16 --seed 8" + kSlow + " -o ";
  const std::string ref_file = path("ref16.h5"), f = path("killed16.h5");
  ASSERT_EQ(shell(mpirun(2) + args + ref_file).status, 0);
  // Start, wait until some replicates are on disk, kill every process hard.
  shell("(" + mpirun(2) + args + f + " > /dev/null 2>&1 &)");
  int done = 0;
  for (int k = 0; k < 400 && done < 3; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    try {
      done = 16 - count_status(read_results(f, false), RecordStatus::Pending);
    } catch (const ResultsFileError&) {  // not created yet
    }
  }
  shell("pkill -9 -f 'ringsim run.*killed16.h5'");
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const ResultsContent killed = read_results(f);  // readable after kill -9
  const int pending = count_status(killed, RecordStatus::Pending);
  ASSERT_GT(pending, 0) << "the run finished before the kill: make it longer";
  ASSERT_LT(pending, 16);
  EXPECT_EQ(killed.provenance.complete, 0);
  // Resume: only the missing ones run (the log says how many).
  const Cmd c = shell_apart(mpirun(2) + args + f + " --resume");
  ASSERT_EQ(c.status, 0) << c.err;
  EXPECT_NE(c.err.find(std::to_string(pending) + " to run"), std::string::npos) << c.err;
  const ResultsContent a = read_results(ref_file), b = read_results(f);
  EXPECT_EQ(b.provenance.complete, 1);
  EXPECT_EQ(b.provenance.runs, 2);
  for (std::size_t i = 0; i < a.records.size(); ++i) {
    ReplicateRecord x = a.records[i], y = b.records[i];
    x.wall_seconds = y.wall_seconds = 0.0;
    EXPECT_EQ(0, std::memcmp(&x, &y, sizeof x)) << "row " << i;
  }
  // Resuming a complete file does nothing and succeeds (requeue-safe).
  const Cmd again = shell_apart(mpirun(2) + args + f + " --resume");
  EXPECT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.err.find("0 to run"), std::string::npos) << again.err;
}

TEST_F(Ensemble, SignalStopsCleanlyWithExitCode75AndResumeFinishes) {
  const std::string args = " run --replicates 24 --seed 8" + kSlow + " -o ";
  const std::string f = path("signalled.h5");
  shell("(" + mpirun(2) + args + f + " > " + path("signalled.log") + " 2>&1; echo $? > " + path("signalled.rc") +
        ") > /dev/null 2>&1 &");
  int done = 0;
  for (int k = 0; k < 400 && done < 2; ++k) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    try {
      done = 24 - count_status(read_results(f, false), RecordStatus::Pending);
    } catch (const ResultsFileError&) {
    }
  }
  // What Slurm's --signal does: SIGUSR1 to the launcher, which forwards it.
  shell("pkill -USR1 -f '^mpirun.*signalled.h5'");
  for (int k = 0; k < 200 && !fs::exists(path("signalled.rc")); ++k)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(fs::exists(path("signalled.rc")));
  const Cmd rc = shell("cat " + path("signalled.rc"));
  const Cmd log = shell("cat " + path("signalled.log"));
  EXPECT_EQ(std::stoi(rc.out), 75) << log.out;
  EXPECT_NE(log.out.find("--resume"), std::string::npos) << log.out;
  const ResultsContent c = read_results(f);
  const int pending = count_status(c, RecordStatus::Pending);
  EXPECT_GT(pending, 0);
  EXPECT_EQ(c.provenance.complete, 0);
  const Cmd r = shell(mpirun(2) + args + f + " --resume");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(count_status(read_results(f), RecordStatus::Ok), 24);
}

TEST_F(Ensemble, RefusesOverwriteMismatchedResumeAndUnwritablePaths) {
  const std::string f = path("refuse.h5");
  const std::string args = " run --replicates 2 --seed 1" + kFast;
  ASSERT_EQ(shell(binary() + args + " -o " + f).status, 0);
  const auto before = fs::last_write_time(f);
  Cmd c = shell(binary() + args + " -o " + f);
  EXPECT_EQ(c.status, 3);
  EXPECT_NE(c.out.find("already exists (2 of 2 replicates done)"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("--force"), std::string::npos) << c.out;
  EXPECT_EQ(fs::last_write_time(f), before);
  c = shell(binary() + args + " --set bonding.dtheta_deg=7 -o " + f + " --resume");
  EXPECT_EQ(c.status, 3);
  EXPECT_NE(c.out.find("configuration differs"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("bonding.dtheta_deg: stored "), std::string::npos) << c.out;
  EXPECT_NE(c.out.find(", requested 7"), std::string::npos) << c.out;
  c = shell(binary() + " run --replicates 3 --seed 1" + kFast + " -o " + f + " --resume");
  EXPECT_EQ(c.status, 3);
  EXPECT_NE(c.out.find("--replicates 2"), std::string::npos) << c.out;
  c = shell(binary() + args + " -o " + path("no/such/dir/x.h5"));
  EXPECT_EQ(c.status, 1);  // checked before anything is opened: a configuration error
  EXPECT_NE(c.out.find("no/such/dir"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("does not exist"), std::string::npos) << c.out;
  EXPECT_FALSE(fs::exists(path("no")));
  c = shell(binary() + args + " --set run.t_max=-1 -o " + path("bad.h5"));
  EXPECT_EQ(c.status, 1);
  EXPECT_NE(c.out.find("run.t_max"), std::string::npos) << c.out;
  EXPECT_FALSE(fs::exists(path("bad.h5")));
  c = shell(binary() + args + " --force -o " + f);
  EXPECT_EQ(c.status, 0) << c.out;
}

TEST_F(Ensemble, FullDiskIsAClearErrorAndLeavesNoFile) {
  const std::string mnt = path("tiny");
  fs::create_directories(mnt);
  if (shell("mount -t tmpfs -o size=48k tmpfs " + mnt).status != 0)
    GTEST_SKIP() << "cannot mount a small tmpfs here (needs root and mount rights)";
  const Cmd c = shell(binary() + " run --replicates 400 --seed 1 --set run.t_max=1 -o " + mnt + "/full.h5");
  const Cmd listing = shell("ls -A " + mnt);
  shell("umount " + mnt);
  EXPECT_EQ(c.status, 3) << c.out;
  EXPECT_NE(c.out.find("No space left on device"), std::string::npos) << c.out;
  EXPECT_EQ(listing.out, "") << "left behind: " << listing.out;
}

TEST_F(Ensemble, SetBeforeTheScenarioFileTakesOneValue) {
  // `--set K=V SCENARIO.toml`: the file stays the positional scenario.
  const std::string scenario = std::string(RINGSIM_SOURCE_DIR) + "/jobs/scenarios/1-baseline.toml";
  const Cmd c = shell(binary() + " run --replicates 1 --seed 1 --set run.t_max=2 " + scenario + " -o " +
                      path("set_first.h5") + " --progress none");
  ASSERT_EQ(c.status, 0) << c.out;
  EXPECT_EQ(read_results(path("set_first.h5"), false).provenance.scenario, "1-baseline");
}

TEST_F(Ensemble, FailedReplicatesAreRecordedAndTheEnsembleGoesOn) {
  const std::string f = path("budget.h5");
  const Cmd c = shell_apart(mpirun(2) + " run --replicates 3 --seed 2" + kFast + " --set run.max_events=300 -o " + f);
  ASSERT_EQ(c.status, 4) << c.err;  // finished, with failed replicates
  EXPECT_NE(c.err.find("3 of 3 replicates failed"), std::string::npos) << c.err;
  const ResultsContent r = read_results(f);
  EXPECT_EQ(count_status(r, RecordStatus::Failed), 3);
  EXPECT_STREQ(r.records[0].termination, "event_budget");
  EXPECT_NE(std::string(r.records[0].error).find("run.max_events"), std::string::npos);
  const std::vector<AggregateGroup> g = aggregate_files({f});
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(summarize_ensemble(g[0].records).n_failed, 3);
}

TEST_F(Ensemble, AggregateMergesShardsDropsDuplicatesAndSeparatesConfigurations) {
  const std::string a = path("shard_a.h5"), b = path("shard_b.h5"), other = path("other.h5");
  ASSERT_EQ(shell(binary() + " run --replicates 3 --seed 1" + kFast + " -o " + a).status, 0);
  ASSERT_EQ(shell(binary() + " run --replicates 2 --seed 2" + kFast + " -o " + b).status, 0);
  ASSERT_EQ(shell(binary() + " run --replicates 2 --seed 1" + kFast + " --set bonding.dtheta_deg=10 -o " + other)
                .status,
            0);
  const std::vector<AggregateGroup> g = aggregate_files({a, b, a, other});
  ASSERT_EQ(g.size(), 2u);
  EXPECT_EQ(g[0].records.size(), 5u);  // 3 + 2 distinct (seed, id)
  EXPECT_EQ(g[0].duplicates, 3);       // the second copy of a
  EXPECT_EQ(g[0].conflicts, 0);
  EXPECT_NE(g[1].sweep.find("run.t_max=25, bonding.joint=welded, bonding.dtheta_deg=10"), std::string::npos) << g[1].sweep;
  const Cmd csv = shell(binary() + " aggregate " + a + " " + b + " " + other + " --format csv");
  ASSERT_EQ(csv.status, 0) << csv.out;
  EXPECT_NE(csv.out.find("dtheta_deg=10"), std::string::npos) << csv.out;
  const Cmd bad = shell(binary() + " aggregate " + a + " --format xml");
  EXPECT_NE(bad.status, 0);
}

TEST_F(Ensemble, AnEnsembleWhoseScenesCannotBeBuiltExitsFour) {
  // A box of 22 asks for a packing fraction of 0.47 (below the bound checked
  // up front) that placement does not reach: every replicate fails at scene
  // building. The file and the table are still written; the exit code says so.
  const std::string f = path("no_scene.h5");
  const Cmd c = shell(binary() + " run --replicates 2 --seed 1 --set geometry.box_length=22 -o " + f);
  EXPECT_EQ(c.status, 4) << c.out;
  EXPECT_NE(c.out.find("2 of 2 replicates failed"), std::string::npos) << c.out;
  const ResultsContent r = read_results(f);
  ASSERT_EQ(r.records.size(), 2u);
  EXPECT_EQ(count_status(r, RecordStatus::Failed), 2);
  const std::string e = r.records[0].error;
  EXPECT_FALSE(e.empty());
  // Cut messages end in "..." instead of mid-word.
  if (e.size() == sizeof r.records[0].error - 1) EXPECT_EQ(e.substr(e.size() - 3), "...") << e;
}

TEST(ReplicateRecord, LongErrorMessagesAreCutWithAnEllipsis) {
  const std::string whole(80, 'a');
  EXPECT_EQ(std::string(blank_record(0, 1, RecordStatus::Failed, "error", whole).error), whole);
  const std::string fits(103, 'b');
  EXPECT_EQ(std::string(blank_record(0, 1, RecordStatus::Failed, "error", fits).error), fits);
  const std::string longer(150, 'c');
  const std::string cut = blank_record(0, 1, RecordStatus::Failed, "error", longer).error;
  EXPECT_EQ(cut, std::string(100, 'c') + "...");
}

TEST_F(Ensemble, OutputThatIsNotARegularFileIsRefused) {
  // A FIFO would block open() forever; a link to /dev/null would let --force
  // replace the device with an HDF5 file (as root). Both: exit 1 at once.
  const std::string fifo = path("out.fifo");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  Cmd c = shell("timeout 60 " + binary() + " run --replicates 1 --seed 1" + kFast + " --force -o " + fifo);
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find("FIFO"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find(fifo), std::string::npos) << c.out;
  const std::string link = path("null.h5");
  ASSERT_EQ(symlink("/dev/null", link.c_str()), 0);
  c = shell("timeout 60 " + binary() + " run --replicates 1 --seed 1" + kFast + " --force -o " + link);
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find("character device"), std::string::npos) << c.out;
  struct stat st {};
  ASSERT_EQ(stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  c = shell(binary() + " run --replicates 1 --seed 1" + kFast + " -o " + path("no_such_dir") + "/x.h5");
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find("does not exist"), std::string::npos) << c.out;
}

TEST_F(Ensemble, ReplicateCountAndSeriesSizeAreBounded) {
  Cmd c = shell(binary() + " run --replicates 100000000 --seed 1 -o " + path("huge.h5"));
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find("--replicates"), std::string::npos) << c.out;
  EXPECT_EQ(c.out.find("bad_alloc"), std::string::npos) << c.out;
  c = shell(binary() + " run --replicates 1000000 --series --seed 1 --set run.sample_interval=0.001 -o " +
            path("huge_series.h5"));
  EXPECT_EQ(c.status, 1) << c.out;
  EXPECT_NE(c.out.find("must be <= 2e9"), std::string::npos) << c.out;
  EXPECT_FALSE(fs::exists(path("huge_series.h5")));
}

namespace {

// The line of `text` that contains `key`, without its newline ("" if none).
std::string line_with(const std::string& text, const std::string& key) {
  const auto at = text.find(key);
  if (at == std::string::npos) return "";
  const auto start = text.rfind('\n', at);
  const auto end = text.find('\n', at);
  return text.substr(start == std::string::npos ? 0 : start + 1,
                     (end == std::string::npos ? text.size() : end) - (start == std::string::npos ? 0 : start + 1));
}

}  // namespace

TEST_F(Ensemble, ResumeOfAnotherConfigurationNamesTheFullKeyAndBothValues) {
  const std::string f = path("resume_key.h5");
  const std::string scene = " --set init.spheres=60 --set init.linkers=60 --set geometry.box_length=25";
  ASSERT_EQ(shell(binary() + " run --replicates 1 --seed 1 --progress none" + scene + " --set run.t_max=20 -o " + f)
                .status,
            0);
  const Cmd c = shell(binary() + " run --replicates 1 --seed 1" + scene + " --set run.t_max=30 -o " + f + " --resume");
  EXPECT_EQ(c.status, 3) << c.out;
  EXPECT_NE(c.out.find("run.t_max: stored 20"), std::string::npos) << c.out;
  EXPECT_NE(c.out.find("requested 30"), std::string::npos) << c.out;
  // Only the key that differs is named.
  EXPECT_EQ(c.out.find("init.spheres:"), std::string::npos) << c.out;
}

TEST_F(Ensemble, ASceneNoReplicateCouldBuildIsRefusedBeforeAnyStarts) {
  // 200000 linkers cannot fit a box of 50: `run` says so at once, exit 1, in
  // the words of `ringsim replicate` (which exits 2 for it), and makes no file.
  const std::string f = path("impossible.h5");
  const Cmd run = shell_apart("timeout 120 " + mpirun(2) + " run --replicates 4 --seed 1 --set init.linkers=200000 -o " +
                              f);
  EXPECT_EQ(run.status, 1) << run.err;
  EXPECT_FALSE(fs::exists(f));
  EXPECT_EQ(run.err.find("replicates done"), std::string::npos) << run.err;
  const Cmd rep = shell("timeout 120 " + binary() + " replicate --seed 1 --set init.linkers=200000");
  EXPECT_EQ(rep.status, 2) << rep.out;
  const std::string said = line_with(rep.out, "scene error");
  ASSERT_FALSE(said.empty()) << rep.out;
  EXPECT_NE(said.find("init.linkers = 200000"), std::string::npos) << said;
  EXPECT_NE(said.find("geometry.box_length = 50"), std::string::npos) << said;
  EXPECT_EQ(line_with(run.err, "scene error"), said) << run.err;
}

TEST_F(Ensemble, AnOutputBelowARegularFileNamesTheFile) {
  const std::string file = path("plain_file");
  { std::FILE* f = std::fopen(file.c_str(), "w"); ASSERT_NE(f, nullptr); std::fclose(f); }
  for (const std::string& out : {file + "/out.h5", file + "/sub/out.h5"}) {
    const Cmd c = shell(binary() + " run --replicates 1 --seed 1" + kFast + " -o " + out);
    EXPECT_EQ(c.status, 1) << c.out;
    EXPECT_NE(c.out.find("'" + file + "' is a regular file, not a directory"), std::string::npos) << c.out;
    EXPECT_NE(c.out.find("--output " + out), std::string::npos) << c.out;
  }
  const Cmd snap = shell(binary() + " replicate --seed 1 --set run.t_max=1 --snapshot " + file + "/final.xyz");
  EXPECT_EQ(snap.status, 1) << snap.out;
  EXPECT_NE(snap.out.find("'" + file + "' is a regular file"), std::string::npos) << snap.out;
}

TEST_F(Ensemble, MpirunOnATerminalShowsTheLiveBarByDefault) {
  // script(1) gives mpirun a pseudo-terminal; the ranks still write into
  // pipes. Default: the bar. Through a pipe, or with --progress log: lines.
  if (shell("command -v script").status != 0) GTEST_SKIP() << "script(1) (util-linux) not installed";
  const std::string run = mpirun(2) + " run --replicates 2 --seed 1" + kFast + " --force -o ";
  const Cmd tty = shell("timeout 300 script -qec '" + run + path("bar.h5") + "' /dev/null < /dev/null");
  ASSERT_EQ(tty.status, 0) << tty.out;
  EXPECT_NE(tty.out.find("\r["), std::string::npos) << tty.out;
  EXPECT_NE(tty.out.find("] 2/2"), std::string::npos) << tty.out;
  EXPECT_EQ(tty.out.find("replicates done"), std::string::npos) << tty.out;
  const Cmd log = shell("timeout 300 script -qec '" + run + path("log.h5") + " --progress log' /dev/null < /dev/null");
  ASSERT_EQ(log.status, 0) << log.out;
  EXPECT_EQ(log.out.find("\r["), std::string::npos) << log.out;
  EXPECT_NE(log.out.find("2/2 replicates done"), std::string::npos) << log.out;
  const Cmd piped = shell_apart(run + path("pipe.h5"));
  ASSERT_EQ(piped.status, 0) << piped.err;
  EXPECT_EQ(piped.err.find("\r["), std::string::npos) << piped.err;
  EXPECT_NE(piped.err.find("2/2 replicates done"), std::string::npos) << piped.err;
}

// A file written before the articulated columns (failed_slices ...
// end_articulated_bodies) existed: tests/data/results_v1.h5, two replicates
// of a small articulated Scenario 1 written by 91f1b59. HDF5 matches
// compound members by name, so it reads with the columns it has and the
// new ones zero, and aggregates.
TEST_F(Ensemble, AFileWithoutTheArticulatedColumnsStillReads) {
  const std::string f = std::string(RINGSIM_TESTDATA_DIR) + "/results_v1.h5";
  const ResultsContent c = read_results(f);
  ASSERT_EQ(c.records.size(), 2u);
  EXPECT_EQ(c.records[0].N_t, 16);
  EXPECT_EQ(c.records[1].N_t, 19);
  EXPECT_EQ(c.records[0].bonds, 44);
  for (const ReplicateRecord& r : c.records) {
    EXPECT_EQ(r.status, static_cast<std::int8_t>(RecordStatus::Ok));
    EXPECT_EQ(r.failed_slices, 0);
    EXPECT_EQ(r.max_residual_after_projection, 0.0);
    EXPECT_EQ(r.end_articulated_bodies, 0);
  }
  const std::vector<AggregateGroup> g = aggregate_files({f});
  ASSERT_EQ(g.size(), 1u);
  EXPECT_EQ(summarize_ensemble(g[0].records).n_ok, 2);
}

// `ringsim run` keeps how closely an articulated replicate held its joints:
// the columns equal `replicate --json`'s "articulated" block for the same
// replicate, and a welded run leaves them zero.
TEST_F(Ensemble, ArticulatedColumnsAreTheReplicatesOwn) {
  const std::string small =
      " --set init.spheres=30 --set init.linkers=30 --set geometry.box_length=20 --set run.t_max=30";
  const std::string f = path("articulated.h5"), w = path("welded_cols.h5");
  ASSERT_EQ(shell(binary() + " run --replicates 2 --seed 3" + small + " -o " + f).status, 0);
  const Cmd js = shell_apart(binary() + " replicate --seed 3 --replicate 1 --json" + small);
  ASSERT_EQ(js.status, 0) << js.err;
  const nlohmann::json a = nlohmann::json::parse(js.out).at("articulated");
  const ReplicateRecord r = read_results(f).records[1];
  EXPECT_EQ(r.failed_slices, a.at("failed_slices").get<std::int64_t>());
  EXPECT_EQ(r.released_held_rows, a.at("released_held_rows").get<std::int64_t>());
  EXPECT_EQ(r.readmitted_held_rows, a.at("readmitted_held_rows").get<std::int64_t>());
  EXPECT_EQ(r.max_residual_after_projection, a.at("max_residual_after_projection").get<double>());
  EXPECT_EQ(r.max_cut_residual, a.at("max_cut_residual").get<double>());
  EXPECT_EQ(r.max_released_residual, a.at("max_released_residual").get<double>());
  EXPECT_EQ(r.max_projection, a.at("max_projection").get<double>());
  EXPECT_EQ(r.end_rigid_bodies, a.at("clusters_at_end").at("rigid_bodies").get<std::int32_t>());
  EXPECT_EQ(r.end_articulated_bodies, a.at("clusters_at_end").at("articulated_bodies").get<std::int32_t>());
  EXPECT_GT(r.end_articulated_bodies, 0);  // the scene forms integrated clusters by t = 30
  EXPECT_GT(r.max_projection, 0.0);
  EXPECT_LT(r.max_residual_after_projection, 1e-8);
  ASSERT_EQ(shell(binary() + " run --replicates 1 --seed 3" + small + " --set bonding.joint=welded -o " + w).status, 0);
  const ReplicateRecord x = read_results(w).records[0];
  EXPECT_EQ(x.end_articulated_bodies + x.end_rigid_bodies, 0);
  EXPECT_EQ(x.max_projection, 0.0);
}
