#include "core/event_queue.hpp"

#include <limits>

namespace ringsim {

void TournamentQueue::reset(int bodies) {
  leaves_ = 1;
  while (leaves_ < bodies) leaves_ *= 2;
  tree_.assign(2 * leaves_, Node{std::numeric_limits<double>::infinity(), 0});
  for (int i = 0; i < leaves_; ++i) tree_[leaves_ + i].body = i;
  for (int k = leaves_ - 1; k >= 1; --k) tree_[k] = earlier(tree_[2 * k], tree_[2 * k + 1]);
}

void TournamentQueue::update(int body, double time) {
  int k = leaves_ + body;
  tree_[k].time = time;
  for (k >>= 1; k >= 1; k >>= 1) {
    const Node w = earlier(tree_[2 * k], tree_[2 * k + 1]);
    if (w.body == tree_[k].body && w.time == tree_[k].time) break;  // nothing above changes
    tree_[k] = w;
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
