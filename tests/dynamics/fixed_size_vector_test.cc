// The integrator's vector operations compiled for the state's length give the same bits as
// SUNDIALS' serial ones, so CVODE takes the same steps with either (the trajectory, the worker's
// path and the replays depend on it).
#include <gtest/gtest.h>

#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>

#include <array>
#include <cmath>
#include <cstring>
#include <random>

#include "fixed_size_vector.h"
#include "forklift/dynamics/dynamics.h"

using namespace forklift;

namespace {

constexpr int N = StateIndex::kSize;

class FixedSizeVector : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_EQ(SUNContext_Create(nullptr, &ctx_), 0);
    std::mt19937 rng(19);
    // Magnitudes over many decades and both signs, a zero, so that rounding differs by formula.
    std::uniform_real_distribution<double> mantissa(-1, 1), decade(-12, 6);
    for (auto* vs : {&plain_, &fast_})
      for (N_Vector& v : *vs) v = N_VNew_Serial(N, ctx_);
    for (int k = 0; k < kVectors; ++k) {
      for (int i = 0; i < N; ++i) {
        const double value = i == 7 ? 0.0 : mantissa(rng) * std::pow(10.0, decade(rng));
        NV_Ith_S(plain_[k], i) = NV_Ith_S(fast_[k], i) = value;
      }
      use_fixed_size_operations(fast_[k]);
    }
  }
  void TearDown() override {
    for (auto* vs : {&plain_, &fast_})
      for (N_Vector v : *vs) N_VDestroy(v);
    SUNContext_Free(&ctx_);
  }
  // The result vector of each pair holds the same bits.
  void expect_same(int k) {
    EXPECT_EQ(std::memcmp(N_VGetArrayPointer(plain_[k]), N_VGetArrayPointer(fast_[k]), N * sizeof(double)), 0)
        << "vector " << k;
  }
  static bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

  static constexpr int kVectors = 4;
  SUNContext ctx_ = nullptr;
  std::array<N_Vector, kVectors> plain_{}, fast_{};
};

TEST_F(FixedSizeVector, OperationsAreInstalledOnlyOnAStateSizedSerialVector) {
  N_Vector other = N_VNew_Serial(N + 1, ctx_);
  const auto serial_sum = other->ops->nvlinearsum;
  use_fixed_size_operations(other);
  EXPECT_EQ(other->ops->nvlinearsum, serial_sum);
  N_VDestroy(other);
  EXPECT_NE(fast_[0]->ops->nvlinearsum, plain_[0]->ops->nvlinearsum);
  N_Vector clone = N_VClone(fast_[0]);  // CVODE's own vectors are clones of the state
  EXPECT_EQ(clone->ops->nvlinearsum, fast_[0]->ops->nvlinearsum);
  N_VDestroy(clone);
}

TEST_F(FixedSizeVector, LinearSumMatchesTheSerialCaseByCase) {
  // Every case of the serial operation: +-1 on either side, a = b, a = -b, in place on x or y.
  const double coefficients[][2] = {{1, 1},    {1, -1},     {-1, 1},  {1, 0.3},  {0.3, 1},     {-1, 0.3},
                                    {0.3, -1}, {0.37, 0.37}, {0.37, -0.37}, {-2.5e-3, 7.1}, {0, 0.9}, {-1, -1}};
  for (const auto& c : coefficients) {
    N_VLinearSum(c[0], plain_[0], c[1], plain_[1], plain_[2]);
    N_VLinearSum(c[0], fast_[0], c[1], fast_[1], fast_[2]);
    expect_same(2);
    N_VLinearSum(c[0], plain_[0], c[1], plain_[3], plain_[3]);  // z = y
    N_VLinearSum(c[0], fast_[0], c[1], fast_[3], fast_[3]);
    expect_same(3);
    N_VLinearSum(c[0], plain_[2], c[1], plain_[1], plain_[2]);  // z = x
    N_VLinearSum(c[0], fast_[2], c[1], fast_[1], fast_[2]);
    expect_same(2);
  }
}

TEST_F(FixedSizeVector, ElementwiseOperationsMatchTheSerial) {
  for (double c : {1.0, -1.0, 0.7}) {
    N_VScale(c, plain_[0], plain_[2]);
    N_VScale(c, fast_[0], fast_[2]);
    expect_same(2);
  }
  N_VProd(plain_[0], plain_[1], plain_[2]);
  N_VProd(fast_[0], fast_[1], fast_[2]);
  expect_same(2);
  N_VAbs(plain_[2], plain_[3]);
  N_VAbs(fast_[2], fast_[3]);
  expect_same(3);
  N_VInv(plain_[3], plain_[2]);
  N_VInv(fast_[3], fast_[2]);
  expect_same(2);
  N_VDiv(plain_[1], plain_[2], plain_[3]);
  N_VDiv(fast_[1], fast_[2], fast_[3]);
  expect_same(3);
  N_VAddConst(plain_[0], 0.25, plain_[2]);
  N_VAddConst(fast_[0], 0.25, fast_[2]);
  expect_same(2);
  N_VCompare(1e-3, plain_[0], plain_[2]);
  N_VCompare(1e-3, fast_[0], fast_[2]);
  expect_same(2);
  EXPECT_EQ(N_VInvTest(plain_[0], plain_[2]), N_VInvTest(fast_[0], fast_[2]));  // entry 7 is zero
  expect_same(2);
  N_VConst(-3.5, plain_[2]);
  N_VConst(-3.5, fast_[2]);
  expect_same(2);
}

TEST_F(FixedSizeVector, ReductionsAddInTheSerialOrder) {
  N_VAbs(plain_[1], plain_[3]);  // weights are positive
  N_VAbs(fast_[1], fast_[3]);
  EXPECT_TRUE(same_bits(N_VWrmsNorm(plain_[0], plain_[3]), N_VWrmsNorm(fast_[0], fast_[3])));
  EXPECT_TRUE(same_bits(N_VWSqrSumLocal(plain_[0], plain_[3]), N_VWSqrSumLocal(fast_[0], fast_[3])));
  EXPECT_TRUE(same_bits(N_VDotProd(plain_[0], plain_[1]), N_VDotProd(fast_[0], fast_[1])));
  EXPECT_TRUE(same_bits(N_VMaxNorm(plain_[0]), N_VMaxNorm(fast_[0])));
  EXPECT_TRUE(same_bits(N_VMin(plain_[0]), N_VMin(fast_[0])));
  EXPECT_GT(N_VWrmsNorm(fast_[0], fast_[3]), 0);
}

}  // namespace
