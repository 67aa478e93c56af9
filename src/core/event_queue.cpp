#include "core/event_queue.hpp"

#include <limits>

namespace ringsim {

void TournamentQueue::reset(int bodies) {
  leaves_ = 1;
  while (leaves_ < bodies) leaves_ *= 2;
  times_.assign(leaves_, std::numeric_limits<double>::infinity());
  tree_.assign(2 * leaves_, 0);
  for (int i = 0; i < leaves_; ++i) tree_[leaves_ + i] = i;
  for (int k = leaves_ - 1; k >= 1; --k) {
    const int a = tree_[2 * k], b = tree_[2 * k + 1];
    tree_[k] = earlier(a, b) ? a : b;
  }
}

void TournamentQueue::update(int body, double time) {
  times_[body] = time;
  for (int k = (leaves_ + body) >> 1; k >= 1; k >>= 1) {
    const int a = tree_[2 * k], b = tree_[2 * k + 1];
    tree_[k] = earlier(a, b) ? a : b;
  }
}

void ReferenceQueue::reset(int bodies) { times_.assign(bodies, std::numeric_limits<double>::infinity()); }

int ReferenceQueue::top() const {
  int best = 0;
  for (int i = 1; i < static_cast<int>(times_.size()); ++i)
    if (times_[i] < times_[best]) best = i;  // strict: lowest id wins ties
  return best;
}

std::unique_ptr<EventQueue> make_queue(QueueKind kind) {
  switch (kind) {
    case QueueKind::Fast: return std::make_unique<TournamentQueue>();
    case QueueKind::Reference: return std::make_unique<ReferenceQueue>();
  }
  return nullptr;
}

}  // namespace ringsim
