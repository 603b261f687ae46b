// A set of UUIDs held as one sorted array: 16 bytes an id, where a std::set takes 64 or more
// (a node of a tree an id). The agent's sync state holds millions of ids for a large backlog
// (its pushed content, and the same ids as its unmerged submission's), which as trees alone
// were GBs.
//
// Reads as a std::set<Uuid> (ordered iteration, contains, size, ==). Inserts in ascending order
// append; others wait in a buffer merged in at the next read, so a set built in any order costs
// one sort. An erase moves the ids after it: cheap for the few an install erases, not for many.
//
// Threading: a const read may merge the buffer, so a set being built (inserted into since its
// last read) is read by one thread at a time; a set no one inserts into is safe to read from
// several.
#pragma once

#include <algorithm>
#include <cstddef>
#include <initializer_list>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

class IdSet {
 public:
  using value_type = Uuid;
  using const_iterator = std::vector<Uuid>::const_iterator;
  using iterator = const_iterator;

  IdSet() = default;
  IdSet(std::initializer_list<Uuid> ids) { insert(ids.begin(), ids.end()); }
  template <typename It>
  IdSet(It first, It last) {
    insert(first, last);
  }

  const_iterator begin() const {
    Settle();
    return sorted_.begin();
  }
  const_iterator end() const {
    Settle();
    return sorted_.end();
  }
  std::size_t size() const {
    Settle();
    return sorted_.size();
  }
  bool empty() const { return sorted_.empty() && pending_.empty(); }
  bool contains(const Uuid& id) const {
    Settle();
    return std::binary_search(sorted_.begin(), sorted_.end(), id);
  }
  std::size_t count(const Uuid& id) const { return contains(id) ? 1 : 0; }

  void insert(const Uuid& id) {
    if (pending_.empty() && (sorted_.empty() || sorted_.back() < id)) {
      sorted_.push_back(id);
    } else {
      pending_.push_back(id);
    }
  }
  // As std::set's hinted insert; the hint is not needed.
  void insert(const_iterator /*hint*/, const Uuid& id) { insert(id); }
  template <typename It>
  void insert(It first, It last) {
    for (; first != last; ++first) insert(*first);
  }
  // Returns the ids erased (0 or 1).
  std::size_t erase(const Uuid& id) {
    Settle();
    const auto at = std::lower_bound(sorted_.begin(), sorted_.end(), id);
    if (at == sorted_.end() || *at != id) return 0;
    sorted_.erase(at);
    return 1;
  }
  void clear() {
    sorted_.clear();
    pending_.clear();
  }

  friend bool operator==(const IdSet& a, const IdSet& b) {
    a.Settle();
    b.Settle();
    return a.sorted_ == b.sorted_;
  }

 private:
  void Settle() const {
    if (pending_.empty()) return;
    std::sort(pending_.begin(), pending_.end());
    const std::size_t middle = sorted_.size();
    sorted_.insert(sorted_.end(), pending_.begin(), pending_.end());
    std::inplace_merge(sorted_.begin(), sorted_.begin() + static_cast<std::ptrdiff_t>(middle),
                       sorted_.end());
    sorted_.erase(std::unique(sorted_.begin(), sorted_.end()), sorted_.end());
    std::vector<Uuid>().swap(pending_);
  }

  mutable std::vector<Uuid> sorted_;   // ascending, each id once
  mutable std::vector<Uuid> pending_;  // inserted out of order, not yet merged
};

}  // namespace fleetmap
