#include "tissue_cut/physics/lane_inverse.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace tissue_cut {

namespace {

constexpr int kLanes = kInverseLanes;

// The loops over lanes are innermost, so that they vectorize; M is a template argument so that
// the others unroll.
template <int M>
inline __attribute__((always_inline)) void invertLanes(double* a, unsigned char* ok) {
  double l[M][M][kLanes], li[M][M][kLanes];
  for (int x = 0; x < kLanes; ++x) ok[x] = 1;
  for (int j = 0; j < M; ++j) {
    double d[kLanes], inv[kLanes];
    for (int x = 0; x < kLanes; ++x) d[x] = a[(j * M + j) * kLanes + x];
    for (int k = 0; k < j; ++k)
      for (int x = 0; x < kLanes; ++x) d[x] -= l[j][k][x] * l[j][k][x];
    for (int x = 0; x < kLanes; ++x) {
      ok[x] &= static_cast<unsigned char>(d[x] > 0);
      l[j][j][x] = std::sqrt(d[x]);
      inv[x] = 1.0 / l[j][j][x];
    }
    for (int i = j + 1; i < M; ++i) {
      double s[kLanes];
      for (int x = 0; x < kLanes; ++x) s[x] = a[(i * M + j) * kLanes + x];
      for (int k = 0; k < j; ++k)
        for (int x = 0; x < kLanes; ++x) s[x] -= l[i][k][x] * l[j][k][x];
      for (int x = 0; x < kLanes; ++x) l[i][j][x] = s[x] * inv[x];
    }
  }
  for (int j = 0; j < M; ++j) {  // L^-1, column by column
    for (int x = 0; x < kLanes; ++x) li[j][j][x] = 1.0 / l[j][j][x];
    for (int i = j + 1; i < M; ++i) {
      double s[kLanes] = {};
      for (int k = j; k < i; ++k)
        for (int x = 0; x < kLanes; ++x) s[x] += l[i][k][x] * li[k][j][x];
      for (int x = 0; x < kLanes; ++x) li[i][j][x] = -s[x] / l[i][i][x];
    }
  }
  for (int i = 0; i < M; ++i)  // A^-1 = L^-T L^-1
    for (int j = 0; j <= i; ++j) {
      double s[kLanes] = {};
      for (int k = i; k < M; ++k)
        for (int x = 0; x < kLanes; ++x) s[x] += li[k][i][x] * li[k][j][x];
      for (int x = 0; x < kLanes; ++x)
        a[(i * M + j) * kLanes + x] = a[(j * M + i) * kLanes + x] = s[x];
    }
}

// Each compiled for the widest vector unit the CPU has (as MassSpring::springTerms()); this
// file is compiled without fused multiply-adds (CMakeLists.txt), so each copy rounds alike.
__attribute__((target_clones("avx512f", "avx2", "default"))) void invert6(double* a,
                                                                          unsigned char* ok) {
  invertLanes<6>(a, ok);
}
__attribute__((target_clones("avx512f", "avx2", "default"))) void invert9(double* a,
                                                                          unsigned char* ok) {
  invertLanes<9>(a, ok);
}
__attribute__((target_clones("avx512f", "avx2", "default"))) void invert12(double* a,
                                                                           unsigned char* ok) {
  invertLanes<12>(a, ok);
}

}  // namespace

void invertSymmetricLanes(int m, double* a, unsigned char* ok) {
  switch (m) {
    case 6:
      invert6(a, ok);
      return;
    case 9:
      invert9(a, ok);
      return;
    case 12:
      invert12(a, ok);
      return;
    default:
      throw std::invalid_argument("invertSymmetricLanes: m must be 6, 9 or 12, not " +
                                  std::to_string(m));
  }
}

}  // namespace tissue_cut
