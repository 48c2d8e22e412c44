#pragma once
// Minimum-cost one-to-one assignment (Kuhn-Munkres / Hungarian method with
// potentials, O(n^2 m)), for any rectangular cost matrix.
#include <vector>

namespace regolith::saliency {

/// `cost` is row-major rows x cols (finite values). Returns, for each row, the
/// assigned column or -1 (when rows > cols, rows - cols rows stay unassigned).
/// The assignment has minimum total cost among all assignments of min(rows,
/// cols) pairs. Throws std::invalid_argument if the size does not match or a
/// cost is not finite.
std::vector<int> solve_assignment(const std::vector<double>& cost, int rows, int cols);

}  // namespace regolith::saliency
