#include "ensemble/run_command.hpp"

#include <mpi.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <limits>
#include <memory>
#include <ostream>
#include <sstream>
#include <utility>
#include <vector>

#include "analysis/ensemble_summary.hpp"
#include "analysis/table5.hpp"
#include "core/scene.hpp"
#include "ensemble/cli_checks.hpp"
#include "ensemble/config.hpp"
#include "ensemble/progress_mode.hpp"
#include "ensemble/replicate_command.hpp"
#include "ensemble/results_file.hpp"
#include "ensemble/scheduler.hpp"
#include "ringsim/version.hpp"

namespace ringsim {

namespace {

using Clock = std::chrono::steady_clock;

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string host_name() {
  char buf[256] = {};
  if (gethostname(buf, sizeof buf - 1) != 0) return "unknown";
  return buf;
}

std::string duration_text(double s) {
  if (!std::isfinite(s) || s < 0) return "?";
  const long v = std::lround(s);
  char buf[32];
  if (v >= 3600) std::snprintf(buf, sizeof buf, "%ldh%02ldm", v / 3600, (v / 60) % 60);
  else if (v >= 60) std::snprintf(buf, sizeof buf, "%ldm%02lds", v / 60, v % 60);
  else std::snprintf(buf, sizeof buf, "%lds", v);
  return buf;
}

// MPI for the lifetime of one `run`: the main thread alone calls MPI.
class MpiSession {
 public:
  MpiSession() {
    int provided = 0;
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    if (provided < MPI_THREAD_FUNNELED) {
      MPI_Finalize();
      throw std::runtime_error("the MPI library does not provide MPI_THREAD_FUNNELED");
    }
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  ~MpiSession() { MPI_Finalize(); }
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  int rank() const { return rank_; }
  int size() const { return size_; }

 private:
  int rank_ = 0, size_ = 1;
};

// Rank 0's value of `s` on every rank (non-blocking, so waiting ranks sleep).
void broadcast(std::string& s) {
  std::uint64_t n = s.size();
  MPI_Request req;
  MPI_Ibcast(&n, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD, &req);
  wait_politely(&req);
  s.resize(n);
  MPI_Ibcast(s.data(), static_cast<int>(n), MPI_CHAR, 0, MPI_COMM_WORLD, &req);
  wait_politely(&req);
}

int broadcast(int v) {
  MPI_Request req;
  MPI_Ibcast(&v, 1, MPI_INT, 0, MPI_COMM_WORLD, &req);
  wait_politely(&req);
  return v;
}

// Runs `step` on rank 0 only; every rank gets the same status back: 0 to go
// on, else `code` (rank 0 has printed prefix + the message).
template <class Step>
int on_rank0(bool root, int code, const char* prefix, std::ostream& err, Step&& step) {
  int status = 0;
  std::string message;
  if (root) {
    try {
      step();
    } catch (const std::exception& e) {
      message = e.what();
      status = code;
    }
  }
  status = broadcast(status);
  if (status != 0 && root) err << prefix << message << '\n';
  return status;
}

std::string scenario_label(const Scenario& sc, const std::string& path) {
  if (!sc.name.empty()) return sc.name;
  if (!path.empty()) return std::filesystem::path(path).stem().string();
  return "default";
}

std::string join(const std::vector<std::string>& v, const char* sep) {
  std::string s;
  for (const std::string& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

// The keys of a configuration written by config_to_toml ("[section]" headers,
// "key = value" lines) as "section.key" -> value, in file order.
std::vector<std::pair<std::string, std::string>> toml_keys(const std::string& toml) {
  std::vector<std::pair<std::string, std::string>> out;
  std::istringstream in(toml);
  std::string line, section;
  while (std::getline(in, line)) {
    if (line.size() >= 2 && line.front() == '[' && line.back() == ']') {
      section = line.substr(1, line.size() - 2);
      continue;
    }
    const auto eq = line.find(" = ");
    if (eq == std::string::npos) continue;
    out.emplace_back(section.empty() ? line.substr(0, eq) : section + "." + line.substr(0, eq), line.substr(eq + 3));
  }
  return out;
}

// Every key whose value differs between the stored and the requested
// configuration, for the refusal message: "run.t_max: stored 200, requested 300".
std::string config_differences(const std::string& stored, const std::string& requested) {
  const auto a = toml_keys(stored), b = toml_keys(requested);
  auto find = [](const std::vector<std::pair<std::string, std::string>>& v, const std::string& key) -> const std::string* {
    for (const auto& kv : v)
      if (kv.first == key) return &kv.second;
    return nullptr;
  };
  std::vector<std::string> diffs;
  for (const auto& [key, value] : a) {
    const std::string* other = find(b, key);
    if (!other) diffs.push_back(key + ": stored " + value + ", not in this version's configuration");
    else if (*other != value) diffs.push_back(key + ": stored " + value + ", requested " + *other);
  }
  for (const auto& [key, value] : b)
    if (!find(a, key)) diffs.push_back(key + ": not stored, requested " + value);
  std::string s;
  for (const std::string& d : diffs) s += (s.empty() ? "" : "; ") + d;
  return s.empty() ? "the same keys and values, written differently" : s;
}

// Progress on rank 0: a live bar or plain lines (ensemble/progress_mode.hpp).
class Progress {
 public:
  Progress(std::ostream& err, std::uint64_t to_run, std::uint64_t done_before, std::uint64_t total, double interval,
           ProgressForm form)
      : err_(err), to_run_(to_run), before_(done_before), total_(total), interval_(interval),
        tty_(form == ProgressForm::Bar), quiet_(form == ProgressForm::None), start_(Clock::now()), last_(start_) {}
  void count(bool failed) {
    ++done_;
    failed_ += failed;
  }
  void tick(bool final = false) {
    if (quiet_) return;
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    if (!final && since < (tty_ ? 0.5 : interval_)) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = elapsed > 0 ? done_ / elapsed : 0.0;
    const double eta = rate > 0 ? (to_run_ - done_) / rate : std::numeric_limits<double>::quiet_NaN();
    const std::uint64_t have = before_ + done_;
    char line[200];
    if (tty_) {
      constexpr int kWidth = 30;
      const int fill = total_ ? static_cast<int>(kWidth * have / total_) : kWidth;
      std::string bar(static_cast<std::size_t>(fill), '#');
      bar.resize(kWidth, '.');
      std::snprintf(line, sizeof line, "\r[%s] %llu/%llu  failed %llu  %.3g rep/s  ETA %s   ", bar.c_str(),
                    static_cast<unsigned long long>(have), static_cast<unsigned long long>(total_),
                    static_cast<unsigned long long>(failed_), rate, final ? "-" : duration_text(eta).c_str());
      err_ << line << (final ? "\n" : "") << std::flush;
    } else {
      std::snprintf(line, sizeof line,
                    "ringsim run: %s %llu/%llu replicates done (%llu failed this run), %.3g replicates/s, "
                    "elapsed %s, ETA %s\n",
                    utc_now().c_str(), static_cast<unsigned long long>(have), static_cast<unsigned long long>(total_),
                    static_cast<unsigned long long>(failed_), rate, duration_text(elapsed).c_str(),
                    final ? "-" : duration_text(eta).c_str());
      err_ << line << std::flush;
    }
  }

 private:
  std::ostream& err_;
  std::uint64_t to_run_, before_, total_, done_ = 0, failed_ = 0;
  double interval_;
  bool tty_, quiet_;
  Clock::time_point start_, last_;
};

// What rank 0 prepared: an open writer and the ids still to run.
struct Prepared {
  std::unique_ptr<ResultsWriter> writer;
  Provenance provenance;
  std::vector<std::uint64_t> ids;
  std::uint64_t done_before = 0;
};

Prepared prepare_output(const RunOptions& opt, const Provenance& fresh, std::ostream& err) {
  Prepared p;
  const bool exists = std::filesystem::exists(opt.output);
  if (exists && !opt.resume && !opt.force) {
    std::string state;
    try {
      const ResultsContent c = read_results(opt.output, false);
      std::uint64_t done = 0;
      for (const ReplicateRecord& r : c.records) done += r.status != static_cast<std::int8_t>(RecordStatus::Pending);
      state = " (" + std::to_string(done) + " of " + std::to_string(c.records.size()) + " replicates done)";
    } catch (const std::exception&) {
      state = " (not a readable ringsim result file)";
    }
    throw std::runtime_error(opt.output + " already exists" + state +
                             ". Use --resume to finish it, or --force to replace it.");
  }
  if (exists && opt.resume) {
    ResultsContent c;
    try {
      c = read_results(opt.output, false);
    } catch (const std::exception& e) {
      throw std::runtime_error(std::string("cannot resume: ") + e.what() + ". Use --force to start over.");
    }
    const Provenance& old = c.provenance;
    if (old.config_hash != fresh.config_hash)
      throw std::runtime_error("cannot resume " + opt.output + ": its configuration differs from this run's (" +
                               config_differences(old.config_toml, fresh.config_toml) + "; config hash " +
                               old.config_hash + " vs " + fresh.config_hash +
                               "). Resume with the same scenario and --set options, or write to a new file.");
    if (old.base_seed != fresh.base_seed || old.replicates != fresh.replicates)
      throw std::runtime_error("cannot resume " + opt.output + ": it holds --replicates " +
                               std::to_string(old.replicates) + " --seed " + std::to_string(old.base_seed) +
                               ", this run asks for --replicates " + std::to_string(fresh.replicates) + " --seed " +
                               std::to_string(fresh.base_seed) + ".");
    if (old.series_length != fresh.series_length)
      throw std::runtime_error("cannot resume " + opt.output + ": the file was written " +
                               (old.series_length ? "with" : "without") + " --series; use the same setting.");
    if (old.version != fresh.version)
      err << "ringsim run: warning: " << opt.output << " was started by ringsim " << old.version << ", this is "
          << fresh.version << "; rows from different versions may differ.\n";
    p.provenance = old;
    p.provenance.runs += 1;
    p.provenance.ranks = fresh.ranks;
    p.provenance.host = fresh.host;
    for (const ReplicateRecord& r : c.records) {
      if (r.status == static_cast<std::int8_t>(RecordStatus::Pending)) p.ids.push_back(r.id);
      else ++p.done_before;
    }
    p.writer = ResultsWriter::open(opt.output);
    return p;
  }
  if (opt.resume) err << "ringsim run: " << opt.output << " does not exist yet: starting a new ensemble.\n";
  p.provenance = fresh;
  p.writer = ResultsWriter::create(opt.output, fresh);
  for (std::uint64_t r = 0; r < fresh.replicates; ++r) p.ids.push_back(r);
  return p;
}

}  // namespace

void add_run_command(CLI::App& app, RunOptions& opt) {
  CLI::App* cmd = app.add_subcommand(
      "run", "Run an ensemble of R seeded replicates over MPI ranks into one HDF5 file, then print Table 5.");
  cmd->footer(
      "Every rank computes; replicates are handed out one at a time. Replicate r always uses the random streams\n"
      "keyed by (--seed, r), so its row is the same whatever the rank count or order (rerun one alone with\n"
      "`ringsim replicate --seed S --replicate r`).\n"
      "Finished replicates reach the file within about a second. After a crash or kill, rerun with --resume:\n"
      "only the missing replicates run. SIGTERM, SIGUSR1 or Ctrl-C stop cleanly with exit code 75 (see below).\n"
      "Examples:\n"
      "  mpirun -np 2 ringsim run --replicates 8 --seed 1 -o default.h5 --set run.t_max=200\n"
      "  mpirun -np 4 ringsim run jobs/scenarios/1-baseline.toml --replicates 1000 --seed 1 -o s1.h5\n"
      "  mpirun -np 4 ringsim run jobs/scenarios/1-baseline.toml --replicates 1000 --seed 1 -o s1.h5 --resume\n"
      "  ringsim aggregate s1.h5 s2.h5 --format markdown\n"
      "Exit codes: 0 done; 1 configuration or command-line error (also an -o that is not a regular file, and\n"
      "bodies too many for the box to hold at random close packing: refused before any replicate starts);\n"
      "3 other error (file, MPI, stdout not writable);\n"
      "4 finished, but at least one replicate failed, e.g. a scene that cannot be built (the file and table\n"
      "are written; see the rows' `error`);\n"
      "75 stopped by a signal (rerun with --resume). Under mpirun, Ctrl-C (or SIGTERM to mpirun) ends with\n"
      "mpirun's own status, 1, not 75; SIGUSR1 to mpirun, or a signal to one rank, gives 75.\n"
      "File layout: docs/OUTPUT.md.");
  cmd->add_option("scenario", opt.scenario, "Scenario TOML file listing deviations from the defaults (optional)")
      ->check(CLI::ExistingFile);
  // At most 1e6: rank 0 holds every row (about 300 bytes each) in memory at
  // the closing write; 1e8 ended in std::bad_alloc.
  cmd->add_option("--replicates,-R", opt.replicates, "Number of replicates R, in [1, 1000000]")
      ->required()
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1000000}));
  cmd->add_option("--seed,-s", opt.seed, "Base seed S, an integer in [0, 2^64 - 1]")->required()->check(unsigned64());
  cmd->add_option("--output,-o", opt.output, "HDF5 result file")->required();
  cmd->add_option("--set", opt.overrides, "Override one key: SECTION.KEY=VALUE (repeatable; a sweep point)")
      ->expected(1)  // one value per --set, so a scenario file after it stays positional
      ->allow_extra_args(false)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  cmd->add_flag("--resume", opt.resume,
                "Finish an existing file: run only its missing replicates (same scenario, --set, -R, --seed); "
                "starts a new file when none exists");
  cmd->add_flag("--force", opt.force, "Replace an existing file (the old one stays until the new one is created)");
  cmd->add_flag("--series", opt.series, "Also store each replicate's sampled N_t(t) in /series/N_t");
  cmd->add_option("--progress-interval", opt.progress_interval, "Seconds between progress lines (--progress log)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--progress", opt.progress,
                  "Progress on rank 0's stderr: bar (live, one line), log (a timestamped line every "
                  "--progress-interval s), none; auto (default): bar when rank 0's stderr is a terminal, or, "
                  "under mpirun/mpiexec, when the launcher's stderr is one (an interactive shell; found through "
                  "/proc on rank 0's node); log otherwise (batch jobs, files, pipes)")
      ->check(CLI::IsMember({"auto", "bar", "log", "none"}));
  cmd->add_option("--format", opt.format, "Closing Table 5 on stdout: table, markdown, csv or json")
      ->check(CLI::IsMember({"table", "markdown", "csv", "json"}));
}

int run_main(const RunOptions& opt, std::ostream& out, std::ostream& err) {
  install_stop_signals();
  MpiSession mpi;
  const bool root = mpi.rank() == 0;

  // The scenario: rank 0 reads the file, every rank parses the same text and
  // fails the same way on bad input (rank 0 reports it).
  std::string text;
  if (const int status = on_rank0(root, 1, "ringsim: configuration error: ", err, [&] {
        if (!opt.scenario.empty()) text = read_scenario_text(opt.scenario);
      }))
    return status;
  broadcast(text);
  Scenario scenario;
  try {
    scenario = load_scenario(text, opt.overrides, opt.scenario.empty() ? "<defaults>" : opt.scenario);
  } catch (const ConfigError& e) {
    if (root) err << "ringsim: configuration error: " << e.what() << '\n';
    return 1;
  }
  const SimParams params = scenario.params;
  // A scene no replicate could build fails every replicate: refuse it now,
  // with the message `ringsim replicate` gives for it (exit 1 here: the
  // configuration is what is wrong, and nothing has started).
  try {
    check_scene_packing(params);
  } catch (const SceneError& e) {
    if (root) err << "ringsim: scene error: " << e.what() << '\n';
    return 1;
  }
  const std::size_t L = opt.series
                            ? static_cast<std::size_t>(std::floor(params.run.t_max / params.run.sample_interval)) + 2
                            : 0;
  // /series/N_t is allocated in full at creation and read whole into rank 0's
  // memory at the closing write: bound its size (8 GB of floats).
  constexpr double kMaxSeriesValues = 2e9;
  if (L && static_cast<double>(L) * static_cast<double>(opt.replicates) > kMaxSeriesValues) {
    if (root)
      err << "ringsim: configuration error: --series with --replicates " << opt.replicates << " and "
          << L << " samples per replicate (run.t_max / run.sample_interval + 2) stores "
          << static_cast<double>(L) * static_cast<double>(opt.replicates)
          << " values: must be <= 2e9 (8 GB, held in memory at the closing write); lower --replicates or "
             "run.t_max, or raise run.sample_interval\n";
    return 1;
  }

  Provenance fresh;
  fresh.version = kVersion;
  fresh.scenario = scenario_label(scenario, opt.scenario);
  fresh.scenario_file = opt.scenario;
  fresh.overrides = join(opt.overrides, "\n");
  fresh.config_toml = config_to_toml(params);
  fresh.config_hash = fnv1a_hex(fresh.config_toml);
  fresh.base_seed = opt.seed;
  fresh.replicates = opt.replicates;
  fresh.ranks = mpi.size();
  fresh.host = host_name();
  fresh.start_time = utc_now();
  fresh.series_length = static_cast<std::int64_t>(L);

  // Before anything opens or removes it: -o must be (or become) a regular file.
  if (const int status = on_rank0(root, 1, "ringsim: configuration error: ", err,
                                  [&] { check_output_path(opt.output, "--output"); }))
    return status;

  Prepared prep;
  if (const int status = on_rank0(root, 3, "ringsim run: ", err, [&] { prep = prepare_output(opt, fresh, err); }))
    return status;

  const ComputeFn compute = [&](std::uint64_t id, const std::atomic<bool>& stop) {
    ReplicateOutput o;
    std::vector<double> samples;
    try {
      const nlohmann::json j = run_replicate(params, opt.seed, id, ReplicateIo{"", "", L ? &samples : nullptr, &stop});
      if (j.at("termination") == "interrupted") {
        o.interrupted = true;
        return o;
      }
      o.record = to_record(j);
    } catch (const std::exception& e) {
      o.record = blank_record(id, opt.seed, RecordStatus::Failed, "error", e.what());  // e.g. a scene that cannot be placed
    }
    if (L) {
      o.series.assign(L, std::numeric_limits<float>::quiet_NaN());
      for (std::size_t k = 0; k < samples.size() && k < L; ++k) o.series[k] = static_cast<float>(samples[k]);
    }
    return o;
  };

  // Rank 0: persist results in batches (at most ~1 s old), show progress.
  std::unique_ptr<Progress> progress;
  std::vector<ReplicateRecord> pending_rows;
  std::vector<float> pending_series;
  auto last_flush = Clock::now();
  auto flush = [&] {
    if (pending_rows.empty()) return;
    prep.writer->write_rows(pending_rows, pending_series);
    pending_rows.clear();
    pending_series.clear();
    last_flush = Clock::now();
  };
  CoordinatorHooks hooks;
  if (root) {
    progress = std::make_unique<Progress>(err, prep.ids.size(), prep.done_before, opt.replicates,
                                          opt.progress_interval, resolve_progress(opt.progress));
    err << "ringsim run: scenario " << prep.provenance.scenario << " (config " << prep.provenance.config_hash
        << "), " << opt.replicates << " replicates, " << prep.ids.size() << " to run, " << mpi.size()
        << (mpi.size() == 1 ? " rank" : " ranks") << ", output " << opt.output << '\n';
    hooks.on_result = [&](const ReplicateOutput& r) {
      pending_rows.push_back(r.record);
      pending_series.insert(pending_series.end(), r.series.begin(), r.series.end());
      progress->count(r.record.status == static_cast<std::int8_t>(RecordStatus::Failed));
      if (pending_rows.size() >= 64) flush();
    };
    hooks.on_tick = [&] {
      if (std::chrono::duration<double>(Clock::now() - last_flush).count() >= 1.0) flush();
      progress->tick();
    };
  }

  std::string failure;
  const ScheduleEnd end = run_schedule(MPI_COMM_WORLD, prep.ids, compute, L, hooks, &failure);

  int code = 0;
  if (root) {
    try {
      if (end != ScheduleEnd::Failed) flush();
      progress->tick(true);
      prep.writer->close();
      prep.writer.reset();
      if (end == ScheduleEnd::Failed) throw std::runtime_error(failure);
      // The closing write: provenance, summary; atomically replaces the file.
      ResultsContent content = read_results(opt.output, true);
      content.provenance = prep.provenance;
      std::uint64_t pending = 0, failed = 0;
      for (const ReplicateRecord& r : content.records) {
        pending += r.status == static_cast<std::int8_t>(RecordStatus::Pending);
        failed += r.status == static_cast<std::int8_t>(RecordStatus::Failed);
      }
      content.provenance.complete = pending == 0;
      content.provenance.end_time = utc_now();
      const EnsembleSummary summary = summarize_ensemble(content.records);
      write_results_atomically(opt.output, content, summary);
      print_table5(out, {ScenarioResult{content.provenance.scenario, join(opt.overrides, ", "), summary}},
                   parse_table_format(opt.format));
      if (end == ScheduleEnd::Interrupted) {
        err << "ringsim run: stopped by a signal; " << (opt.replicates - pending) << " of " << opt.replicates
            << " replicates are in " << opt.output << ". Rerun with --resume to finish.\n";
        code = kExitInterrupted;
      } else if (pending > 0) {
        err << "ringsim run: " << pending << " replicates still pending; rerun with --resume.\n";
        code = kExitInterrupted;
      } else if (failed > 0) {
        std::string first_error;
        for (const ReplicateRecord& r : content.records)
          if (r.status == static_cast<std::int8_t>(RecordStatus::Failed)) {
            first_error = "replicate " + std::to_string(r.id) + ": " + r.termination +
                          (r.error[0] ? std::string(": ") + r.error : std::string());
            break;
          }
        err << "ringsim run: " << failed << " of " << opt.replicates << " replicates failed (first: " << first_error
            << "); their rows are in " << opt.output << " with status failed.\n";
        code = kExitReplicatesFailed;
      }
    } catch (const std::exception& e) {
      err << "ringsim run: " << e.what() << "\nFinished replicates written before the error are in " << opt.output
          << "; rerun with --resume once the problem is fixed.\n";
      code = 3;
    }
  }
  return broadcast(code);
}

}  // namespace ringsim
