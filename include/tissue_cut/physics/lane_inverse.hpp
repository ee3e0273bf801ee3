// Inverses of small symmetric positive definite matrices, kInverseLanes at once: the physics'
// cluster preconditioner inverts each cluster's 6 x 6, 9 x 9 or 12 x 12 block of A every step.
// One matrix alone is a chain of square roots and divisions, each waiting for the last; matrices
// side by side in the lanes of a vector register share that wait.
#pragma once

namespace tissue_cut {

constexpr int kInverseLanes = 8;

/// Inverts kInverseLanes symmetric m x m matrices (m = 6, 9 or 12) in place, by Cholesky:
/// A = L L^T, then A^-1 = L^-T L^-1. `a` holds element e (row-major) of lane x at
/// a[e * kInverseLanes + x]. ok[x] is set to 1 where lane x is positive definite (a then holds its
/// inverse), 0 where it is not (a then holds what the arithmetic made of it). Each lane takes
/// the same operations in the same order whatever the others hold, so a matrix's inverse has the
/// same bits in any lane; fused multiply-adds are not used. Throws std::invalid_argument for
/// another m.
void invertSymmetricLanes(int m, double* a, unsigned char* ok);

}  // namespace tissue_cut
