#pragma once
// Priority queues over bodies. Each body owns exactly one pending event (its
// earliest predicted one); the queue orders bodies by (event time, body id).
// The id breaks ties, so every implementation yields the same sequence.
// Stale events are not removed: an event records its partner's impulse
// counter and is discarded when popped if the partner has moved on (lazy
// invalidation, as in DynamO and Smallenburg's EDMD).
//
// Implementations (a coarse plug-in, hence the virtual interface):
//  - CalendarQueue: Paul's bounded priority queue (G. Paul, J. Comput. Phys.
//    221, 615 (2007), as used by Smallenburg's EDMD): a ring of M time
//    buckets of equal width after a base time, the current bucket's bodies in
//    a small binary heap, later ones in unsorted per-bucket lists and those
//    past the ring (or never) in an overflow list, re-binned when the ring is
//    used up. Update and top are O(1) on average when the width suits the
//    event rate; the width is re-chosen at every re-binning.
//  - ReferenceQueue: a linear scan; slow and obviously correct, for tests.

#include <memory>
#include <vector>

#include "core/intrusive_lists.hpp"
#include "core/params.hpp"

namespace ringsim {

class EventQueue {
 public:
  virtual ~EventQueue() = default;
  virtual void reset(int bodies) = 0;
  virtual void update(int body, double time) = 0;
  virtual int top() const = 0;  // body with the earliest event
  virtual double time(int body) const = 0;
};

class CalendarQueue final : public EventQueue {
 public:
  void reset(int bodies) override;
  void update(int body, double time) override;
  int top() const override;
  double time(int body) const override { return times_[body]; }

 private:
  // where_[b]: b's bucket (0 .. M-1), or one of these.
  static constexpr int kHeap = -1, kOverflow = -2;
  bool before(int a, int b) const { return times_[a] < times_[b] || (times_[a] == times_[b] && a < b); }
  void place(int b) const;
  void unlink(int b) const;
  void link(int b, int list) const;  // list: a bucket, or M_ for the overflow
  void heap_push(int b) const;
  void heap_remove(int b) const;
  void sift_up(std::size_t k) const;
  void sift_down(std::size_t k) const;
  void refill() const;   // the heap empty: the next bucket, or a re-binning
  void rebin() const;    // a new base and width from the overflow list (binned_ false: no finite time)

  // Invariant: with k(b) = floor((times_[b] - base_) / width_), computed as
  // (times_[b] - base_) * inv_width_, the heap holds every b with k <= cur_,
  // bucket j holds those with k = j for cur_ < j < M_, the overflow list the
  // rest (k >= M_, infinite times) and every body before the first re-binning.
  // k is monotone in the time, so every heap time precedes every other.
  // Mutable: top() refills the heap lazily.
  int M_ = 1;
  std::vector<double> times_;
  mutable std::vector<int> where_;
  mutable IntrusiveLists lists_;  // list j < M_: bucket j; list M_: the overflow
  mutable std::vector<int> heap_, pos_;
  mutable double base_ = 0.0, inv_width_ = 1.0;
  mutable int cur_ = 0;
  mutable bool binned_ = false;
  mutable std::vector<double> scratch_;  // rebin's finite times
};

class ReferenceQueue final : public EventQueue {
 public:
  void reset(int bodies) override;
  void update(int body, double time) override { times_[body] = time; }
  int top() const override;
  double time(int body) const override { return times_[body]; }

 private:
  std::vector<double> times_;
};

std::unique_ptr<EventQueue> make_queue(QueueKind kind);

}  // namespace ringsim
