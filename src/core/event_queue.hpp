#pragma once
// Priority queues over bodies. Each body owns exactly one pending event (its
// earliest predicted one); the queue orders bodies by (event time, body id).
// The id breaks ties, so every implementation yields the same sequence.
// Stale events are not removed: an event records its partner's impulse
// counter and is discarded when popped if the partner has moved on (lazy
// invalidation, as in DynamO and Smallenburg's EDMD).
//
// Implementations (a coarse plug-in, hence the virtual interface):
//  - TournamentQueue: a complete binary tournament tree over the bodies;
//    update is O(log N) with one comparison per level, no allocation. Each
//    node holds its winner's time with its id (no indirect load per level),
//    and an update stops at the first node whose winner and time are
//    unchanged: nothing above it can change.
//  - ReferenceQueue: a linear scan; slow and obviously correct, for tests.

#include <memory>
#include <vector>

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

class TournamentQueue final : public EventQueue {
 public:
  void reset(int bodies) override;
  void update(int body, double time) override;
  int top() const override { return tree_[1].body; }
  double time(int body) const override { return tree_[leaves_ + body].time; }

 private:
  struct Node {
    double time;
    int body;
  };
  static const Node& earlier(const Node& a, const Node& b) {
    return a.time < b.time || (a.time == b.time && a.body < b.body) ? a : b;
  }
  int leaves_ = 1;
  std::vector<Node> tree_;  // size 2 * leaves_; node k: winner of its subtree; leaves padded with +inf
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
