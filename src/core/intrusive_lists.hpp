#pragma once
// Intrusive doubly linked lists over items 0 .. n-1 (each item in at most
// one list): a head per list, next/prev per item, O(1) insert and remove,
// no allocation after reset. The cell grid (bodies per cell) and the
// calendar queue (bodies per time bucket) keep their lists in one.

#include <vector>

namespace ringsim {

struct IntrusiveLists {
  std::vector<int> head, next, prev;  // -1: none

  void reset(int lists, int items) {
    head.assign(lists, -1);
    next.assign(items, -1);
    prev.assign(items, -1);
  }
  void push_front(int item, int list) {
    prev[item] = -1;
    next[item] = head[list];
    if (head[list] >= 0) prev[head[list]] = item;
    head[list] = item;
  }
  // `list` must be the list that holds item.
  void remove(int item, int list) {
    if (prev[item] >= 0) next[prev[item]] = next[item];
    else head[list] = next[item];
    if (next[item] >= 0) prev[next[item]] = prev[item];
    next[item] = prev[item] = -1;
  }
};

}  // namespace ringsim
