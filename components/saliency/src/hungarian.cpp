#include "regolith/saliency/hungarian.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace regolith::saliency {

namespace {

// Square-or-wide case (n <= m). a(i, j) is the cost of row i, column j
// (0-based). Shortest augmenting paths with row potentials u and column
// potentials v; column 0 is a virtual start.
std::vector<int> assign_wide(int n, int m, const std::vector<double>& a, bool transposed, int lda) {
  auto cost = [&](int i, int j) {
    return transposed ? a[static_cast<size_t>(j) * static_cast<size_t>(lda) + static_cast<size_t>(i)]
                      : a[static_cast<size_t>(i) * static_cast<size_t>(lda) + static_cast<size_t>(j)];
  };
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> u(static_cast<size_t>(n) + 1, 0.0), v(static_cast<size_t>(m) + 1, 0.0);
  std::vector<int> owner(static_cast<size_t>(m) + 1,
                         0);  // owner[j] = row (1-based) on column j
  std::vector<int> prev(static_cast<size_t>(m) + 1, 0);
  std::vector<double> slack(static_cast<size_t>(m) + 1);
  std::vector<char> done(static_cast<size_t>(m) + 1);
  for (int row = 1; row <= n; ++row) {
    owner[0] = row;
    int col = 0;
    std::fill(slack.begin(), slack.end(), inf);
    std::fill(done.begin(), done.end(), 0);
    while (true) {
      done[static_cast<size_t>(col)] = 1;
      const int i = owner[static_cast<size_t>(col)];
      double delta = inf;
      int next = -1;
      for (int j = 1; j <= m; ++j) {
        if (done[static_cast<size_t>(j)]) continue;
        const double reduced = cost(i - 1, j - 1) - u[static_cast<size_t>(i)] - v[static_cast<size_t>(j)];
        if (reduced < slack[static_cast<size_t>(j)]) {
          slack[static_cast<size_t>(j)] = reduced;
          prev[static_cast<size_t>(j)] = col;
        }
        if (slack[static_cast<size_t>(j)] < delta) {
          delta = slack[static_cast<size_t>(j)];
          next = j;
        }
      }
      for (int j = 0; j <= m; ++j) {
        if (done[static_cast<size_t>(j)]) {
          u[static_cast<size_t>(owner[static_cast<size_t>(j)])] += delta;
          v[static_cast<size_t>(j)] -= delta;
        } else {
          slack[static_cast<size_t>(j)] -= delta;
        }
      }
      col = next;
      if (owner[static_cast<size_t>(col)] == 0) break;
    }
    // Flip the augmenting path back to the start.
    while (col != 0) {
      const int p = prev[static_cast<size_t>(col)];
      owner[static_cast<size_t>(col)] = owner[static_cast<size_t>(p)];
      col = p;
    }
  }
  std::vector<int> result(static_cast<size_t>(n), -1);
  for (int j = 1; j <= m; ++j) {
    if (owner[static_cast<size_t>(j)] > 0) result[static_cast<size_t>(owner[static_cast<size_t>(j)] - 1)] = j - 1;
  }
  return result;
}

}  // namespace

std::vector<int> solve_assignment(const std::vector<double>& cost, int rows, int cols) {
  if (rows < 0 || cols < 0 || cost.size() != static_cast<size_t>(rows) * static_cast<size_t>(cols)) {
    throw std::invalid_argument("solve_assignment: cost has " + std::to_string(cost.size()) +
                                " entries, expected rows*cols = " + std::to_string(static_cast<long>(rows) * cols));
  }
  for (size_t k = 0; k < cost.size(); ++k) {
    if (!std::isfinite(cost[k])) {
      throw std::invalid_argument("solve_assignment: cost[" + std::to_string(k) + "] is not finite");
    }
  }
  if (rows == 0 || cols == 0) return std::vector<int>(static_cast<size_t>(rows), -1);
  if (rows <= cols) return assign_wide(rows, cols, cost, false, cols);
  // Tall: solve the transpose (columns as rows) and invert the mapping.
  const std::vector<int> by_col = assign_wide(cols, rows, cost, true, cols);
  std::vector<int> result(static_cast<size_t>(rows), -1);
  for (int j = 0; j < cols; ++j) {
    if (by_col[static_cast<size_t>(j)] >= 0) result[static_cast<size_t>(by_col[static_cast<size_t>(j)])] = j;
  }
  return result;
}

}  // namespace regolith::saliency
