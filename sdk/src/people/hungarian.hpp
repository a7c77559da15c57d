// The Hungarian method (Kuhn-Munkres) for a square cost matrix: the assignment of rows to columns
// with the least total cost, exactly, in O(n^3). The shortest-augmenting-path form with row and
// column potentials (Jonker-Volgenant's relaxation as e-maxx writes it): n augmentations, each a
// Dijkstra-like scan of the columns over reduced costs. Chosen over a library's (Debian's
// libdlib-dev has max_cost_assignment) because the tracker's matrices are small (at most
// 128 x 128), its costs are real numbers (dlib's wants integers), and this form needs only
// six arrays of n + 1 entries, sized once: solving allocates nothing.
#pragma once

#include <cstddef>
#include <vector>

namespace kata::people {

// Solves square assignment problems of up to `capacity` rows. Not thread-safe (one per tracker).
class Hungarian {
 public:
  explicit Hungarian(int capacity);
  // cost: n x n, row-major (row stride n), finite. row_to_col[i] receives the column of row i.
  // n <= capacity; allocates nothing.
  void solve(const double* cost, int n, int* row_to_col);
  int capacity() const { return capacity_; }

 private:
  int capacity_;
  std::vector<double> u_, v_, min_v_;
  std::vector<int> p_, way_;
  std::vector<char> used_;
};

}  // namespace kata::people
