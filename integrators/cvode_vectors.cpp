// The SUNDIALS plumbing of the CVODE integrator (cvode_vectors.hpp).
#include "integrators/cvode_vectors.hpp"

#include <cvode/cvode.h>

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include "integrators/cvode.hpp"
#include "lib/error.hpp"

namespace jamflow {
namespace cvode_detail {

void free_cvode_memory(void* mem) {
  CVodeFree(&mem);
}

namespace {

// Vector kernels. Debian's SUNDIALS 6.4.1 is built without optimisation (its N_VDotProd_Serial
// runs at ~9 ns per element, measured), and CVODE spends most of its time in these kernels, so
// the serial vectors get Eigen implementations of every operation CVODE and the Krylov solvers
// use. Clones (all of CVODE's work vectors) copy the table. Semantics follow nvector_serial.
using Vec = Eigen::Map<Eigen::ArrayXd>;
Vec arr(N_Vector v) {
  return Vec(NV_DATA_S(v), static_cast<Eigen::Index>(NV_LENGTH_S(v)));
}

namespace kernel {
void linear_sum(sunrealtype a, N_Vector x, sunrealtype b, N_Vector y, N_Vector z) {
  arr(z) = a * arr(x) + b * arr(y);
}
void constant(sunrealtype c, N_Vector z) {
  arr(z).setConstant(c);
}
void prod(N_Vector x, N_Vector y, N_Vector z) {
  arr(z) = arr(x) * arr(y);
}
void div(N_Vector x, N_Vector y, N_Vector z) {
  arr(z) = arr(x) / arr(y);
}
void scale(sunrealtype c, N_Vector x, N_Vector z) {
  arr(z) = c * arr(x);
}
void abs(N_Vector x, N_Vector z) {
  arr(z) = arr(x).abs();
}
void inv(N_Vector x, N_Vector z) {
  arr(z) = arr(x).inverse();
}
void add_const(N_Vector x, sunrealtype b, N_Vector z) {
  arr(z) = arr(x) + b;
}
// Reductions as OpenMP SIMD loops (Eigen's AVX-512 reductions trip GCC 12's
// -Wmaybe-uninitialized inside its own intrinsics headers).
sunrealtype dot(N_Vector x, N_Vector y) {
  const double* a = NV_DATA_S(x);
  const double* b = NV_DATA_S(y);
  const sunindextype n = NV_LENGTH_S(x);
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (sunindextype i = 0; i < n; ++i)
    sum += a[i] * b[i];
  return sum;
}
sunrealtype max_norm(N_Vector x) {
  const double* a = NV_DATA_S(x);
  const sunindextype n = NV_LENGTH_S(x);
  double m = 0.0;
#pragma omp simd reduction(max : m)
  for (sunindextype i = 0; i < n; ++i)
    m = std::max(m, std::abs(a[i]));
  return m;
}
sunrealtype wsqr_sum(N_Vector x, N_Vector w) {
  const double* a = NV_DATA_S(x);
  const double* b = NV_DATA_S(w);
  const sunindextype n = NV_LENGTH_S(x);
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (sunindextype i = 0; i < n; ++i)
    sum += (a[i] * b[i]) * (a[i] * b[i]);
  return sum;
}
sunrealtype wsqr_sum_mask(N_Vector x, N_Vector w, N_Vector id) {
  const double* xd = NV_DATA_S(x);
  const double* wd = NV_DATA_S(w);
  const double* m = NV_DATA_S(id);
  double sum = 0.0;
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) {
    if (m[i] > 0.0)
      sum += (xd[i] * wd[i]) * (xd[i] * wd[i]);
  }
  return sum;
}
sunrealtype wrms_norm(N_Vector x, N_Vector w) {
  return std::sqrt(wsqr_sum(x, w) / double(NV_LENGTH_S(x)));
}
sunrealtype wrms_norm_mask(N_Vector x, N_Vector w, N_Vector id) {
  return std::sqrt(wsqr_sum_mask(x, w, id) / double(NV_LENGTH_S(x)));
}
sunrealtype min(N_Vector x) {
  const double* a = NV_DATA_S(x);
  const sunindextype n = NV_LENGTH_S(x);
  double m = std::numeric_limits<double>::max();
#pragma omp simd reduction(min : m)
  for (sunindextype i = 0; i < n; ++i)
    m = std::min(m, a[i]);
  return m;
}
sunrealtype wl2_norm(N_Vector x, N_Vector w) {
  return std::sqrt(wsqr_sum(x, w));
}
sunrealtype l1_norm(N_Vector x) {
  const double* a = NV_DATA_S(x);
  const sunindextype n = NV_LENGTH_S(x);
  double sum = 0.0;
#pragma omp simd reduction(+ : sum)
  for (sunindextype i = 0; i < n; ++i)
    sum += std::abs(a[i]);
  return sum;
}
void compare(sunrealtype c, N_Vector x, N_Vector z) {
  const double* xd = NV_DATA_S(x);
  double* zd = NV_DATA_S(z);
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i)
    zd[i] = std::abs(xd[i]) >= c ? 1.0 : 0.0;
}
sunbooleantype inv_test(N_Vector x, N_Vector z) {
  // Like nvector_serial: z = 1/x where x != 0, false if any x is 0.
  const double* a = NV_DATA_S(x);
  double* b = NV_DATA_S(z);
  bool ok = true;
  for (sunindextype i = 0; i < NV_LENGTH_S(x); ++i) {
    if (a[i] == 0.0)
      ok = false;
    else
      b[i] = 1.0 / a[i];
  }
  return ok ? SUNTRUE : SUNFALSE;
}
sunrealtype min_quotient(N_Vector num, N_Vector denom) {
  const double* n = NV_DATA_S(num);
  const double* d = NV_DATA_S(denom);
  double q = std::numeric_limits<double>::max();
  for (sunindextype i = 0; i < NV_LENGTH_S(num); ++i) {
    if (d[i] != 0.0)
      q = std::min(q, n[i] / d[i]);
  }
  return q;
}
int linear_combination(int nv, sunrealtype* c, N_Vector* x, N_Vector z) {
  // z may alias x[0] (CVODE relies on it); another alias goes through a temporary.
  for (int i = 1; i < nv; ++i) {
    if (x[i] == z) {
      Eigen::ArrayXd acc = c[0] * arr(x[0]);
      for (int k = 1; k < nv; ++k)
        acc += c[k] * arr(x[k]);
      arr(z) = acc;
      return 0;
    }
  }
  Vec out = arr(z);
  if (x[0] != z) {
    out = c[0] * arr(x[0]);
  } else if (c[0] != 1.0) {
    out *= c[0];
  }
  for (int i = 1; i < nv; ++i)
    out += c[i] * arr(x[i]);
  return 0;
}
int scale_add_multi(int nv, sunrealtype* a, N_Vector x, N_Vector* y, N_Vector* z) {
  for (int i = 0; i < nv; ++i)
    arr(z[i]) = a[i] * arr(x) + arr(y[i]);
  return 0;
}
int dot_multi(int nv, N_Vector x, N_Vector* y, sunrealtype* d) {
  for (int i = 0; i < nv; ++i)
    d[i] = dot(x, y[i]);
  return 0;
}
}  // namespace kernel

}  // namespace

void install_kernels(N_Vector v) {
  N_Vector_Ops o = v->ops;
  o->nvlinearsum = kernel::linear_sum;
  o->nvconst = kernel::constant;
  o->nvprod = kernel::prod;
  o->nvdiv = kernel::div;
  o->nvscale = kernel::scale;
  o->nvabs = kernel::abs;
  o->nvinv = kernel::inv;
  o->nvaddconst = kernel::add_const;
  o->nvdotprod = kernel::dot;
  o->nvmaxnorm = kernel::max_norm;
  o->nvwrmsnorm = kernel::wrms_norm;
  o->nvwrmsnormmask = kernel::wrms_norm_mask;
  o->nvmin = kernel::min;
  o->nvwl2norm = kernel::wl2_norm;
  o->nvl1norm = kernel::l1_norm;
  o->nvcompare = kernel::compare;
  o->nvinvtest = kernel::inv_test;
  o->nvminquotient = kernel::min_quotient;
  o->nvlinearcombination = kernel::linear_combination;
  o->nvscaleaddmulti = kernel::scale_add_multi;
  o->nvdotprodmulti = kernel::dot_multi;
  o->nvdotprodlocal = kernel::dot;
  o->nvmaxnormlocal = kernel::max_norm;
  o->nvminlocal = kernel::min;
  o->nvl1normlocal = kernel::l1_norm;
  o->nvinvtestlocal = kernel::inv_test;
  o->nvminquotientlocal = kernel::min_quotient;
  o->nvwsqrsumlocal = kernel::wsqr_sum;
  o->nvwsqrsummasklocal = kernel::wsqr_sum_mask;
}

}  // namespace cvode_detail

using namespace cvode_detail;

double cvode_kernel_discrepancy(std::size_t n, unsigned seed) {
  SUNContext raw = nullptr;
  if (SUNContext_Create(nullptr, &raw) != 0)
    throw IntegrationError("CVODE: SUNContext_Create failed");
  const ContextPtr ctx(raw);
  const auto len = static_cast<sunindextype>(n);
  // Index 0: nvector_serial's own kernels, 1: ours; six vectors each.
  std::array<std::array<VectorPtr, 6>, 2> v;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> init(6 * n);
  for (auto& x : init)
    x = u(rng);
  for (std::size_t k = 0; k < n; k += 7)
    init[n + k] = 0.0;  // zeros in the second vector (inv_test, min_quotient)
  for (int impl = 0; impl < 2; ++impl) {
    for (int j = 0; j < 6; ++j) {
      v[impl][j].reset(N_VNew_Serial(len, ctx.get()));
      if (impl == 1)
        install_kernels(v[impl][j].get());
      std::copy_n(&init[j * n], n, NV_DATA_S(v[impl][j].get()));
    }
  }
  double worst = 0.0;
  const auto rel = [&](double a, double b) {
    worst = std::max(worst, std::abs(a - b) / (1.0 + std::abs(a)));
  };
  const auto same = [&](int j) {
    for (std::size_t i = 0; i < n; ++i)
      rel(NV_DATA_S(v[0][j].get())[i], NV_DATA_S(v[1][j].get())[i]);
  };
  const auto run = [&](const auto& op) {
    for (int impl = 0; impl < 2; ++impl) {
      std::array<N_Vector, 6> w;
      for (int j = 0; j < 6; ++j)
        w[j] = v[impl][j].get();
      op(w.data(), impl);
    }
  };
  run([&](N_Vector* x, int) { N_VLinearSum(0.3, x[0], -1.7, x[1], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VLinearSum(0.3, x[0], -1.7, x[1], x[1]); });
  same(1);
  run([&](N_Vector* x, int) { N_VProd(x[0], x[2], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VDiv(x[0], x[2], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VScale(2.5, x[3], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VAbs(x[3], x[4]); });
  same(4);
  run([&](N_Vector* x, int) { N_VInv(x[2], x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VAddConst(x[3], 0.25, x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VCompare(0.5, x[3], x[5]); });
  same(5);
  run([&](N_Vector* x, int) {
    N_VConst(0.0, x[5]);
    N_VInvTest(x[1], x[5]);
  });
  same(5);
  const auto scalar = [&](const auto& f) {
    std::array<double, 2> r{};
    run([&](N_Vector* x, int i) { r[i] = f(x); });
    rel(r[0], r[1]);
  };
  scalar([](N_Vector* x) { return N_VDotProd(x[0], x[2]); });
  scalar([](N_Vector* x) { return N_VMaxNorm(x[0]); });
  scalar([](N_Vector* x) { return N_VWrmsNorm(x[0], x[2]); });
  scalar([](N_Vector* x) { return N_VWrmsNormMask(x[0], x[2], x[3]); });
  scalar([](N_Vector* x) { return N_VMin(x[0]); });
  scalar([](N_Vector* x) { return N_VWL2Norm(x[0], x[2]); });
  scalar([](N_Vector* x) { return N_VL1Norm(x[0]); });
  scalar([](N_Vector* x) { return N_VMinQuotient(x[0], x[1]); });
  scalar([](N_Vector* x) { return double(N_VInvTest(x[1], x[5])); });
  // Fused operations, with the one alias nvector_serial supports (z == x[0]).
  std::array<double, 3> c{0.5, -2.0, 3.0};
  run([&](N_Vector* x, int) { N_VLinearCombination(3, c.data(), x, x[5]); });
  same(5);
  run([&](N_Vector* x, int) { N_VLinearCombination(3, c.data(), x, x[0]); });
  same(0);
  run([&](N_Vector* x, int) {
    std::array<N_Vector, 2> ys{x[1], x[2]}, zs{x[4], x[2]};
    N_VScaleAddMulti(2, c.data(), x[3], ys.data(), zs.data());
  });
  same(4);
  same(2);
  std::array<std::array<double, 2>, 2> d{};
  run([&](N_Vector* x, int i) {
    std::array<N_Vector, 2> ys{x[1], x[2]};
    N_VDotProdMulti(2, x[3], ys.data(), d[i].data());
  });
  rel(d[0][0], d[1][0]);
  rel(d[0][1], d[1][1]);
  return worst;
}

}  // namespace jamflow
