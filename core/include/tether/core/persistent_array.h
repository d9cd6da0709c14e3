#pragma once
// An array whose copies share what they have in common: a tree of nodes with 8 children each,
// the values in the leaves. Copying the array copies one pointer; changing an element copies
// only the nodes on the way from the root to its leaf (O(log n) values and pointers), so the
// other copies keep seeing the old value and share every other node with the changed one.
// Particle filters keep one map per particle this way (FastSLAM's landmarks, fast_slam.h):
// resampling copies N maps in O(N), and a particle's update costs O(log n) per landmark.
//
// Nodes are shared through std::shared_ptr<const Node>: copies may be read and changed from
// different threads as long as each array object is used by one thread at a time.
#include <cstddef>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace tether {

template <typename T>
class PersistentArray {
 public:
  static constexpr int kBits = 3;
  static constexpr std::size_t kBranch = std::size_t{1} << kBits;

  PersistentArray() = default;

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

  /// Element i (i < size(); throws std::out_of_range otherwise). The reference stays valid
  /// while any array that shares the element's leaf lives.
  const T& operator[](std::size_t i) const {
    if (i >= size_)
      throw std::out_of_range("PersistentArray: index " + std::to_string(i) + " of " + std::to_string(size_));
    const Node* n = root_.get();
    for (int level = depth_; level > 0; --level) n = n->children[Slot(i, level)].get();
    return n->values[i & (kBranch - 1)];
  }

  /// Sets element i (i < size()): copies the nodes on its path, the other copies unchanged.
  void Set(std::size_t i, T value) {
    if (i >= size_)
      throw std::out_of_range("PersistentArray: index " + std::to_string(i) + " of " + std::to_string(size_));
    root_ = Assign(root_.get(), depth_, i, std::move(value));
  }

  /// Appends an element.
  void PushBack(T value) {
    if (size_ == Capacity()) {  // a new root above the old one
      auto root = std::make_shared<Node>();
      if (root_ != nullptr) {
        root->children.push_back(std::move(root_));
        ++depth_;
      }
      root_ = std::move(root);
    }
    root_ = Assign(root_.get(), depth_, size_, std::move(value));
    ++size_;
  }

  /// Calls f(i, element) for every element in order (O(n), no lookups).
  template <typename F>
  void ForEach(F&& f) const {
    std::size_t i = 0;
    if (root_ != nullptr) Visit(root_.get(), depth_, &i, f);
  }

 private:
  struct Node {
    std::vector<std::shared_ptr<const Node>> children;  // levels above 0
    std::vector<T> values;                              // level 0
  };

  static std::size_t Slot(std::size_t i, int level) { return (i >> (kBits * level)) & (kBranch - 1); }
  std::size_t Capacity() const { return root_ == nullptr ? 0 : std::size_t{1} << (kBits * (depth_ + 1)); }

  // A copy of n (a new node where n is null) with element i set, at `level` above the leaves.
  static std::shared_ptr<const Node> Assign(const Node* n, int level, std::size_t i, T value) {
    auto copy = n != nullptr ? std::make_shared<Node>(*n) : std::make_shared<Node>();
    const std::size_t slot = Slot(i, level);
    if (level == 0) {
      if (slot < copy->values.size()) {
        copy->values[slot] = std::move(value);
      } else {
        copy->values.push_back(std::move(value));  // appending: slot == values.size()
      }
    } else if (slot < copy->children.size()) {
      copy->children[slot] = Assign(copy->children[slot].get(), level - 1, i, std::move(value));
    } else {
      copy->children.push_back(Assign(nullptr, level - 1, i, std::move(value)));
    }
    return copy;
  }

  template <typename F>
  static void Visit(const Node* n, int level, std::size_t* i, F& f) {
    if (level == 0) {
      for (const T& v : n->values) f((*i)++, v);
      return;
    }
    for (const auto& c : n->children) Visit(c.get(), level - 1, i, f);
  }

  std::shared_ptr<const Node> root_;
  int depth_ = 0;  // levels above the leaves
  std::size_t size_ = 0;
};

}  // namespace tether
