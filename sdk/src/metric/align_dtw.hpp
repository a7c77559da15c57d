// The offline reference alignment (kata score --align dtw): a subsequence DTW of a whole student clip against
// a teacher clip over the same static-blocks projections the online Aligner compares
// (reference.hpp), so the two can be judged against each other (kata score --align dtw).
//
// With c(n, j) = |s_n - t_j|: D(0, j) = c(0, j) (open begin: the student may start anywhere in
// the teacher), D(n, j) = c(n, j) + min(D(n-1, j-1), D(n-1, j), D(n, j-1)), the path ends at the
// teacher frame argmin_j D(N-1, j) (open end) and is traced back. Each student frame's match is
// the last teacher frame the path pairs with it. Time and memory O(N x M) (one byte per cell):
// offline only.
#pragma once

#include <vector>

#include "metric/reference.hpp"

namespace kata::metric {

// The matched teacher frame of each of n student frames whose static-blocks projections are
// `projections` (n x stride floats, Reference::alignment_projection layout). A pose reference
// matches frame 0 throughout. Throws kInvalidArgument for n < 1.
std::vector<int> subsequence_dtw(const Reference& reference, const float* projections, int n);

}  // namespace kata::metric
