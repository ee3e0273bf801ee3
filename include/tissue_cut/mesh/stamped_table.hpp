// StampedTable: a few keys noted out of many, without arrays over all of them.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace tissue_cut {

/// An open-addressing table of 64-bit keys, each with a value, at most half full. begin() empties
/// it in O(1) (a slot is taken in this pass where its stamp is the pass's), so a call that notes a
/// few slots or edges out of a mesh's thousands costs what it notes, and no page of an array over
/// every slot is touched for the first time in the middle of a tick. Keys are spread by Fibonacci
/// hashing: consecutive ids (a record's new tets) land apart.
template <class Value>
class StampedTable {
 public:
  /// A new, empty pass, sized for `expected` keys (it grows past that if need be).
  void begin(std::size_t expected = 0) {
    std::size_t size = std::max<std::size_t>(64, keys_.size());
    while (size < 2 * expected) size *= 2;
    if (size > keys_.size()) resize(size);
    count_ = 0;
    if (++pass_ == 0) {
      std::fill(stamps_.begin(), stamps_.end(), 0u);
      pass_ = 1;
    }
  }
  bool contains(std::uint64_t key) const {
    return !keys_.empty() && stamps_[placeOf(key)] == pass_;
  }
  /// The value noted with key (which must be in this pass).
  const Value& at(std::uint64_t key) const { return values_[placeOf(key)]; }
  /// Notes key with value (replacing the value where key is in already); true if key was new.
  bool put(std::uint64_t key, const Value& value) {
    if (2 * (count_ + 1) > keys_.size()) grow();
    const std::size_t i = placeOf(key);
    const bool fresh = stamps_[i] != pass_;
    if (fresh) {
      stamps_[i] = pass_;
      keys_[i] = key;
      ++count_;
    }
    values_[i] = value;
    return fresh;
  }

 private:
  std::size_t placeOf(std::uint64_t key) const {
    const std::size_t mask = keys_.size() - 1;
    std::size_t i = static_cast<std::size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
    while (stamps_[i] == pass_ && keys_[i] != key) i = (i + 1) & mask;
    return i;
  }
  void resize(std::size_t size) {  // a power of two; the pass's keys are dropped
    keys_.assign(size, 0);
    values_.assign(size, Value{});
    stamps_.assign(size, 0u);
    pass_ = 0;
    shift_ = 64 - __builtin_ctzll(size);
  }
  void grow() {  // twice the size, the pass's keys placed again
    std::vector<std::pair<std::uint64_t, Value>> kept;
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (stamps_[i] == pass_) kept.emplace_back(keys_[i], values_[i]);
    resize(std::max<std::size_t>(64, 2 * keys_.size()));
    pass_ = 1;
    count_ = 0;
    for (const auto& [key, value] : kept) put(key, value);
  }

  std::vector<std::uint64_t> keys_;
  std::vector<Value> values_;
  std::vector<unsigned> stamps_;
  unsigned pass_ = 0;
  std::size_t count_ = 0;
  int shift_ = 64;
};

}  // namespace tissue_cut
