#include "ensemble/scheduler.hpp"

#include <chrono>
#include <condition_variable>
#include <csignal>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>

namespace ringsim {

namespace {

std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "the signal flag must be lock-free");

extern "C" void record_signal(int sig) { g_signal.store(sig); }

constexpr auto kPoll = std::chrono::milliseconds(1);

// Message tags. Worker -> rank 0: Request (payload: the previous result, or
// nothing), Bye (payload: a last result, or nothing; the worker's final
// message), Notice (a signal arrived on that rank). Rank 0 -> worker: Assign
// (int64 id, -1 = no more work), Stop (drop what you run, say bye).
enum Tag : int { kRequest = 101, kBye = 102, kNotice = 103, kAssign = 104, kStop = 105 };

// Runs replicates on a thread of its own; the owner polls for results.
class ComputeThread {
 public:
  explicit ComputeThread(const ComputeFn& fn) : fn_(fn), thread_([this] { loop(); }) {}
  ~ComputeThread() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  ComputeThread(const ComputeThread&) = delete;
  ComputeThread& operator=(const ComputeThread&) = delete;

  void submit(std::uint64_t id) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = id;
    }
    cv_.notify_all();
  }
  // A finished result, waiting up to `wait` for one.
  std::optional<ReplicateOutput> poll(std::chrono::milliseconds wait) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait_for(lock, wait, [this] { return result_.has_value(); });
    std::optional<ReplicateOutput> out = std::move(result_);
    result_.reset();
    return out;
  }
  void request_stop() { stop_.store(true); }

 private:
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      cv_.wait(lock, [this] { return quit_ || job_.has_value(); });
      if (quit_) return;
      const std::uint64_t id = *job_;
      job_.reset();
      lock.unlock();
      ReplicateOutput out = fn_(id, stop_);
      lock.lock();
      result_ = std::move(out);
      cv_.notify_all();
    }
  }

  const ComputeFn& fn_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<std::uint64_t> job_;
  std::optional<ReplicateOutput> result_;
  bool quit_ = false;
  std::thread thread_;  // last: starts after the members it uses
};

std::vector<char> pack(const ReplicateOutput* out, std::size_t series_length) {
  if (!out) return {};
  std::vector<char> buf(sizeof(ReplicateRecord) + series_length * sizeof(float));
  std::memcpy(buf.data(), &out->record, sizeof(ReplicateRecord));
  if (series_length > 0) {
    if (out->series.size() != series_length) throw std::logic_error("series of the wrong length");
    std::memcpy(buf.data() + sizeof(ReplicateRecord), out->series.data(), series_length * sizeof(float));
  }
  return buf;
}

std::optional<ReplicateOutput> unpack(const std::vector<char>& buf, std::size_t series_length) {
  if (buf.empty()) return std::nullopt;
  if (buf.size() != sizeof(ReplicateRecord) + series_length * sizeof(float))
    throw std::runtime_error("ringsim run: malformed result message (" + std::to_string(buf.size()) + " bytes)");
  ReplicateOutput out;
  std::memcpy(&out.record, buf.data(), sizeof(ReplicateRecord));
  out.series.resize(series_length);
  if (series_length > 0)
    std::memcpy(out.series.data(), buf.data() + sizeof(ReplicateRecord), series_length * sizeof(float));
  return out;
}

void send_bytes(MPI_Comm comm, int dest, int tag, const std::vector<char>& buf) {
  // Results are small (~0.4 kB, plus 4 bytes per N_t sample): a blocking send
  // completes eagerly or as soon as rank 0 polls.
  MPI_Send(buf.data(), static_cast<int>(buf.size()), MPI_BYTE, dest, tag, comm);
}

std::vector<char> recv_bytes(MPI_Comm comm, const MPI_Status& probed) {
  int count = 0;
  MPI_Get_count(&probed, MPI_BYTE, &count);
  std::vector<char> buf(static_cast<std::size_t>(count));
  MPI_Recv(buf.data(), count, MPI_BYTE, probed.MPI_SOURCE, probed.MPI_TAG, comm, MPI_STATUS_IGNORE);
  return buf;
}

// ---- Worker ranks -----------------------------------------------------------

ScheduleEnd run_worker(MPI_Comm comm, const ComputeFn& compute, std::size_t L) {
  ComputeThread worker(compute);
  const auto& signal = g_signal;
  bool busy = false, stopping = false, noticed = false, interrupted = false;
  std::optional<ReplicateOutput> last;  // finished after a Stop arrived
  send_bytes(comm, 0, kRequest, {});
  for (;;) {
    if (signal.load() != 0 && !noticed) {
      noticed = true;
      interrupted = true;
      worker.request_stop();
      send_bytes(comm, 0, kNotice, {});
    }
    if (busy) {
      if (std::optional<ReplicateOutput> r = worker.poll(kPoll)) {
        busy = false;
        if (r->interrupted) interrupted = true;
        const ReplicateOutput* res = r->interrupted ? nullptr : &*r;
        if (stopping) last = std::move(r);
        else send_bytes(comm, 0, kRequest, pack(res, L));
      }
    } else {
      std::this_thread::sleep_for(kPoll);
    }
    int flag = 0;
    MPI_Status st;
    MPI_Iprobe(0, MPI_ANY_TAG, comm, &flag, &st);
    if (flag) {
      if (st.MPI_TAG == kAssign) {
        std::int64_t id = -1;
        MPI_Recv(&id, 1, MPI_INT64_T, 0, kAssign, comm, MPI_STATUS_IGNORE);
        if (id < 0) {
          send_bytes(comm, 0, kBye, {});
          return interrupted ? ScheduleEnd::Interrupted : ScheduleEnd::Complete;
        }
        worker.submit(static_cast<std::uint64_t>(id));
        busy = true;
      } else if (st.MPI_TAG == kStop) {
        MPI_Recv(nullptr, 0, MPI_BYTE, 0, kStop, comm, MPI_STATUS_IGNORE);
        stopping = true;
        interrupted = true;
        worker.request_stop();
      } else {
        throw std::runtime_error("ringsim run: unexpected message tag " + std::to_string(st.MPI_TAG));
      }
    }
    if (stopping && !busy) {
      const ReplicateOutput* res = last && !last->interrupted ? &*last : nullptr;
      send_bytes(comm, 0, kBye, pack(res, L));
      return ScheduleEnd::Interrupted;
    }
  }
}

// ---- Rank 0 -------------------------------------------------------------------

ScheduleEnd run_coordinator(MPI_Comm comm, const std::vector<std::uint64_t>& ids, const ComputeFn& compute,
                            std::size_t L, const CoordinatorHooks& hooks, std::string* failure) {
  int size = 1;
  MPI_Comm_size(comm, &size);
  enum class State { Active, Finishing, Stopping, Done };
  std::vector<State> state(static_cast<std::size_t>(size), State::Active);
  std::deque<std::uint64_t> queue(ids.begin(), ids.end());
  ComputeThread local(compute);
  bool local_busy = false, local_done = false;
  bool draining = false, failed = false;
  const auto& signal = g_signal;

  auto deliver = [&](const ReplicateOutput& r) {
    if (failed) return;
    try {
      if (hooks.on_result) hooks.on_result(r);
    } catch (const std::exception& e) {
      failed = true;
      if (failure) *failure = e.what();
    }
  };
  auto drain = [&] {
    if (draining) return;
    draining = true;
    local.request_stop();
    for (int w = 1; w < size; ++w)
      if (state[w] == State::Active) {
        MPI_Send(nullptr, 0, MPI_BYTE, w, kStop, comm);
        state[w] = State::Stopping;
      }
  };
  auto next_id = [&]() -> std::int64_t {
    if (draining || queue.empty()) return -1;
    const std::uint64_t id = queue.front();
    queue.pop_front();
    return static_cast<std::int64_t>(id);
  };

  for (;;) {
    if (signal.load() != 0 || failed) drain();
    if (local_busy) {
      if (std::optional<ReplicateOutput> r = local.poll(kPoll)) {
        local_busy = false;
        if (!r->interrupted) deliver(*r);
      }
    }
    if (!local_busy && !local_done) {
      const std::int64_t id = next_id();
      if (id >= 0) {
        local.submit(static_cast<std::uint64_t>(id));
        local_busy = true;
      } else {
        local_done = true;
      }
    }
    for (;;) {
      int flag = 0;
      MPI_Status st;
      MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, comm, &flag, &st);
      if (!flag) break;
      const int w = st.MPI_SOURCE;
      const std::vector<char> buf = recv_bytes(comm, st);
      if (std::optional<ReplicateOutput> r = unpack(buf, L)) deliver(*r);
      if (st.MPI_TAG == kRequest) {
        // Only Active workers get an answer: drain() has sent the others Stop.
        if (state[w] == State::Active) {
          const std::int64_t id = next_id();
          if (id < 0) state[w] = State::Finishing;
          MPI_Send(&id, 1, MPI_INT64_T, w, kAssign, comm);
        }
      } else if (st.MPI_TAG == kBye) {
        state[w] = State::Done;
      } else if (st.MPI_TAG == kNotice) {
        drain();
      }
    }
    if (hooks.on_tick && !failed) {
      try {
        hooks.on_tick();
      } catch (const std::exception& e) {
        failed = true;
        if (failure) *failure = e.what();
      }
    }
    bool all_done = local_done && !local_busy;
    for (int w = 1; w < size; ++w) all_done = all_done && state[w] == State::Done;
    if (all_done) break;
    if (!local_busy) std::this_thread::sleep_for(kPoll);
  }
  if (failed) return ScheduleEnd::Failed;
  return draining ? ScheduleEnd::Interrupted : ScheduleEnd::Complete;
}

}  // namespace

const std::atomic<int>& install_stop_signals() {
  struct sigaction sa {};
  sa.sa_handler = record_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0;
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGUSR1, &sa, nullptr);
  sa.sa_flags = SA_RESETHAND;  // a second Ctrl-C ends the program at once
  sigaction(SIGINT, &sa, nullptr);
  return g_signal;
}

ScheduleEnd run_schedule(MPI_Comm comm, const std::vector<std::uint64_t>& ids, const ComputeFn& compute,
                         std::size_t series_length, const CoordinatorHooks& hooks, std::string* failure) {
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) return run_coordinator(comm, ids, compute, series_length, hooks, failure);
  return run_worker(comm, compute, series_length);
}

void wait_politely(MPI_Request* request) {
  for (;;) {
    int done = 0;
    MPI_Test(request, &done, MPI_STATUS_IGNORE);
    if (done) return;
    std::this_thread::sleep_for(kPoll);
  }
}

}  // namespace ringsim
