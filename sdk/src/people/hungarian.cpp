#include "people/hungarian.hpp"

#include <limits>

namespace kata::people {

Hungarian::Hungarian(int capacity)
    : capacity_(capacity),
      u_(static_cast<size_t>(capacity) + 1),
      v_(static_cast<size_t>(capacity) + 1),
      min_v_(static_cast<size_t>(capacity) + 1),
      p_(static_cast<size_t>(capacity) + 1),
      way_(static_cast<size_t>(capacity) + 1),
      used_(static_cast<size_t>(capacity) + 1) {}

// Rows and columns are 1-based inside (column 0 is the augmenting path's virtual start); p[j] is
// the row matched to column j, u and v the potentials, which keep every reduced cost
// cost(i, j) - u[i] - v[j] non-negative, and zero on matched pairs.
void Hungarian::solve(const double* cost, int n, int* row_to_col) {
  const double inf = std::numeric_limits<double>::infinity();
  double* u = u_.data();
  double* v = v_.data();
  double* min_v = min_v_.data();
  int* p = p_.data();
  int* way = way_.data();
  char* used = used_.data();
  const auto at = [&](int i, int j) { return cost[static_cast<size_t>(i - 1) * static_cast<size_t>(n) + static_cast<size_t>(j - 1)]; };
  for (int j = 0; j <= n; ++j) u[j] = v[j] = 0.0, p[j] = 0, way[j] = 0;
  for (int i = 1; i <= n; ++i) {
    p[0] = i;
    int j0 = 0;
    for (int j = 0; j <= n; ++j) min_v[j] = inf, used[j] = 0;
    do {
      used[j0] = 1;
      const int i0 = p[j0];
      double delta = inf;
      int j1 = 0;
      for (int j = 1; j <= n; ++j) {
        if (used[j]) continue;
        const double reduced = at(i0, j) - u[i0] - v[j];
        if (reduced < min_v[j]) min_v[j] = reduced, way[j] = j0;
        if (min_v[j] < delta) delta = min_v[j], j1 = j;
      }
      for (int j = 0; j <= n; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          min_v[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {  // flip the augmenting path
      const int j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  for (int j = 1; j <= n; ++j) row_to_col[p[j] - 1] = j - 1;
}

}  // namespace kata::people
