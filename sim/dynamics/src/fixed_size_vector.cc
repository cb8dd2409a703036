// CVODE spent about a fifth of a manoeuvre's instructions in the serial vector's operations on
// 40 entries (a loop of unknown length behind a few calls each, 11 linear sums a step); with the
// length known they are unrolled and vectorised. Element-wise formulas keep the serial case
// analysis where it changes the rounding (a (x + y) is not a x + a y); reductions add in index
// order like the serial loops (GCC keeps that order without -ffast-math), so the integrator
// takes the same steps to the last bit.
#include "fixed_size_vector.h"

#include <nvector/nvector_serial.h>

#include <Eigen/Core>
#include <cmath>

#include "forklift/dynamics/dynamics.h"

namespace forklift {
namespace {

constexpr int N = StateIndex::kSize;

inline double* data(N_Vector v) { return NV_DATA_S(v); }
// Element-wise operations read and write entry i together, so z may be x or y; a fixed-size map
// lets them run two entries at a time with no overlap checks (a loop over raw pointers that may
// alias was kept scalar).
using Vec = Eigen::Array<double, N, 1>;
inline Eigen::Map<Vec> map(N_Vector v) { return Eigen::Map<Vec>(NV_DATA_S(v)); }

void linear_sum(double a, N_Vector x, double b, N_Vector y, N_Vector z) {
  // With a or b = +-1 every serial case equals a x + b y exactly; a = +-b it factors the scale out.
  if (a == 1 || b == 1 || a == -1 || b == -1 || (a != b && a != -b)) map(z) = a * map(x) + b * map(y);
  else if (a == b) map(z) = a * (map(x) + map(y));
  else map(z) = a * (map(x) - map(y));
}

void constant(double c, N_Vector z) { map(z).setConstant(c); }
void product(N_Vector x, N_Vector y, N_Vector z) { map(z) = map(x) * map(y); }
void quotient(N_Vector x, N_Vector y, N_Vector z) { map(z) = map(x) / map(y); }
void scale(double c, N_Vector x, N_Vector z) { map(z) = c * map(x); }
void absolute(N_Vector x, N_Vector z) { map(z) = map(x).abs(); }
void inverse(N_Vector x, N_Vector z) { map(z) = 1.0 / map(x); }
void add_constant(N_Vector x, double b, N_Vector z) { map(z) = map(x) + b; }

double dot(N_Vector xv, N_Vector yv) {
  const double* x = data(xv);
  const double* y = data(yv);
  double sum = 0;
  for (int i = 0; i < N; ++i) sum += x[i] * y[i];
  return sum;
}

double max_norm(N_Vector xv) {
  const double* x = data(xv);
  double m = 0;
  for (int i = 0; i < N; ++i) m = std::abs(x[i]) > m ? std::abs(x[i]) : m;
  return m;
}

double weighted_square_sum(N_Vector xv, N_Vector wv) {
  const double* x = data(xv);
  const double* w = data(wv);
  double sum = 0;
  for (int i = 0; i < N; ++i) {
    const double p = x[i] * w[i];
    sum += p * p;
  }
  return sum;
}

double weighted_rms_norm(N_Vector xv, N_Vector wv) { return std::sqrt(weighted_square_sum(xv, wv) / N); }

double minimum(N_Vector xv) {
  const double* x = data(xv);
  double m = x[0];
  for (int i = 1; i < N; ++i) m = x[i] < m ? x[i] : m;
  return m;
}

void compare(double c, N_Vector xv, N_Vector zv) {
  const double* x = data(xv);
  double* z = data(zv);
  for (int i = 0; i < N; ++i) z[i] = std::abs(x[i]) >= c ? 1.0 : 0.0;
}

sunbooleantype inverse_test(N_Vector xv, N_Vector zv) {
  const double* x = data(xv);
  double* z = data(zv);
  bool no_zero = true;
  for (int i = 0; i < N; ++i) {
    if (x[i] == 0) no_zero = false;
    else z[i] = 1.0 / x[i];
  }
  return no_zero ? SUNTRUE : SUNFALSE;
}

}  // namespace

void use_fixed_size_operations(N_Vector v) {
  if (N_VGetVectorID(v) != SUNDIALS_NVEC_SERIAL || N_VGetLength(v) != N) return;
  N_Vector_Ops ops = v->ops;
  ops->nvlinearsum = linear_sum;
  ops->nvconst = constant;
  ops->nvprod = product;
  ops->nvdiv = quotient;
  ops->nvscale = scale;
  ops->nvabs = absolute;
  ops->nvinv = inverse;
  ops->nvaddconst = add_constant;
  ops->nvdotprod = dot;
  ops->nvmaxnorm = max_norm;
  ops->nvmaxnormlocal = max_norm;
  ops->nvwrmsnorm = weighted_rms_norm;
  ops->nvwsqrsumlocal = weighted_square_sum;
  ops->nvmin = minimum;
  ops->nvminlocal = minimum;
  ops->nvcompare = compare;
  ops->nvinvtest = inverse_test;
  ops->nvinvtestlocal = inverse_test;
}

}  // namespace forklift
