// Integrator back ends behind Simulation. SUNDIALS 6.4 C API: every object takes a SUNContext.
#include "forklift/dynamics/simulation.h"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "fixed_size_vector.h"
#include "forklift/dynamics/load_on_forks.h"

namespace forklift {

IntegratorKind parse_integrator(const std::string& name) {
  if (name == "cvode") return IntegratorKind::kCvodeBdf;
  if (name == "dopri5") return IntegratorKind::kDopri5;
  if (name == "rk4") return IntegratorKind::kRk4;
  throw std::invalid_argument("unknown integrator '" + name + "' (expected cvode, dopri5 or rk4)");
}

const char* integrator_name(IntegratorKind kind) {
  switch (kind) {
    case IntegratorKind::kCvodeBdf: return "cvode";
    case IntegratorKind::kDopri5: return "dopri5";
    case IntegratorKind::kRk4: return "rk4";
  }
  return "?";
}

namespace {

// Typical magnitude of each state component: absolute tolerance = rtol * scale, so one rtol
// sets a consistent accuracy for positions, angles, rates, filters and torques.
StateVector tolerance_scale() {
  StateVector s;
  s.segment<3>(StateIndex::kQ + kX).setConstant(0.1);        // m
  s.segment<3>(StateIndex::kQ + kAwc).setConstant(0.1);      // rad
  s.segment<3>(StateIndex::kQ + kAvr1).setConstant(10.0);    // rad, wheel spin angles
  s.segment<3>(StateIndex::kQdot + kX).setConstant(1.0);     // m/s
  s.segment<3>(StateIndex::kQdot + kAwc).setConstant(1.0);   // rad/s
  s.segment<3>(StateIndex::kQdot + kAvr1).setConstant(10.0); // rad/s
  for (int d = 0; d < kNumDriven; ++d) s.segment<3>(StateIndex::kDriven + 3 * d) << 0.1, 1.0, 10.0;
  s[StateIndex::kTorque] = s[StateIndex::kBrake] = 100.0;    // N m
  s.segment<2 * kNumWheels>(StateIndex::kTyre).setConstant(0.01);  // m, a bristle at full grip: mu / sigma0
  s.segment<2>(StateIndex::kBrakeStick).setConstant(1.0);          // a brake bristle at full torque
  return s;
}

// The Newton matrix A = I - gamma J of CVODE has the model's structure:
// - q' = q-dot exactly, so the q rows of A are [I, -gamma I, 0];
// - each driven coordinate's filter depends on its own three states alone, the drive and brake
//   lags on themselves alone;
// - q-dot, the tyre bristles and the brake bristles (17 states) depend on everything; a truck
//   without bristle tyres or a sticking brake leaves those states constant (rows and columns of
//   J zero), and then only q-dot's 9 are coupled.
// So the filters (four 3x3) and lags (two scalars) are solved on their own, q is eliminated
// (dq = b_q + gamma dv), and only the coupled system (9 to 17) is factorised, where SUNDIALS'
// dense solver factorised all 40.
namespace structure {
constexpr int kQ = StateIndex::kQ, kV = StateIndex::kQdot, kF = StateIndex::kDriven, kNF = 3 * kNumDriven;
constexpr int kL = StateIndex::kTorque, kNL = 2;
constexpr int kMaxCoupled = kNumDynamic + 2 * kNumWheels + 2;  // q-dot, tyre bristles, brake bristles
static_assert(StateIndex::kTyre + 2 * kNumWheels + 2 == StateIndex::kSize, "tyre and brake bristles end the state");
static_assert(kL == kF + kNF && kL + kNL == StateIndex::kTyre, "filters, lags, then bristles");
}  // namespace structure

// CVODE's Jacobian and Newton matrix as one fixed-size Eigen matrix: copying it and forming
// I - gamma J are a few vector instructions, where SUNDIALS' dense matrix walks column pointers.
using DenseJacobian = Eigen::Matrix<double, StateIndex::kSize, StateIndex::kSize>;
DenseJacobian& dense(SUNMatrix A) { return *static_cast<DenseJacobian*>(A->content); }

SUNMatrix make_matrix(SUNContext ctx) {
  SUNMatrix A = SUNMatNewEmpty(ctx);
  if (!A) return nullptr;
  A->content = new DenseJacobian;
  A->ops->getid = [](SUNMatrix) { return SUNMATRIX_CUSTOM; };
  A->ops->clone = [](SUNMatrix A) { return make_matrix(A->sunctx); };
  A->ops->destroy = [](SUNMatrix A) {
    delete &dense(A);
    A->content = nullptr;
    SUNMatFreeEmpty(A);
  };
  A->ops->zero = [](SUNMatrix A) {
    dense(A).setZero();
    return 0;
  };
  A->ops->copy = [](SUNMatrix from, SUNMatrix to) {
    dense(to) = dense(from);
    return 0;
  };
  A->ops->scaleaddi = [](sunrealtype c, SUNMatrix A) {  // A = c A + I
    dense(A) *= c;
    dense(A).diagonal().array() += 1.0;
    return 0;
  };
  return A;
}

// LU with partial pivoting of the coupled system, at most 17 unknowns, in place (row-major, so
// each elimination step's update runs along contiguous rows).
class CoupledLu {
 public:
  static constexpr int kMax = structure::kMaxCoupled;
  double& at(int i, int j) { return a_[i * kMax + j]; }

  // False if a pivot is zero or not finite (CVODE then retries with a smaller step).
  bool factorise(int n) {
    n_ = n;
    for (int k = 0; k < n; ++k) {
      int p = k;
      for (int i = k + 1; i < n; ++i)
        if (std::abs(at(i, k)) > std::abs(at(p, k))) p = i;
      pivot_[k] = p;
      if (p != k)
        for (int j = 0; j < n; ++j) std::swap(at(k, j), at(p, j));
      const double d = at(k, k);
      if (!(d != 0 && std::isfinite(d))) return false;
      const double inv = 1.0 / d;
      const double* rk = &a_[k * kMax];
      for (int i = k + 1; i < n; ++i) {
        double* ri = &a_[i * kMax];
        const double l = ri[k] *= inv;
        for (int j = k + 1; j < n; ++j) ri[j] -= l * rk[j];
      }
    }
    return true;
  }

  void solve(double* x) const {
    const int n = n_;
    for (int k = 0; k < n; ++k) std::swap(x[k], x[pivot_[k]]);
    for (int i = 1; i < n; ++i) {
      const double* ri = &a_[i * kMax];
      double v = x[i];
      for (int j = 0; j < i; ++j) v -= ri[j] * x[j];
      x[i] = v;
    }
    for (int i = n - 1; i >= 0; --i) {
      const double* ri = &a_[i * kMax];
      double v = x[i];
      for (int j = i + 1; j < n; ++j) v -= ri[j] * x[j];
      x[i] = v / ri[i];
    }
  }

 private:
  std::array<double, kMax * kMax> a_{};
  std::array<int, kMax> pivot_{};
  int n_ = 0;
};

bool bristle_tyres(const TruckParams& truck) { return truck.contact.tyre != TyreModel::kPaper; }
bool brake_sticks(const TruckParams& truck) { return truck.drive.brake_stick_angle_rad > 0; }

struct StructuredSolver {
  std::array<Eigen::PartialPivLU<Eigen::Matrix3d>, kNumDriven> filters;
  CoupledLu coupled;
  int n_coupled = 0;
  std::array<int, structure::kMaxCoupled> coupled_state{};  // state index of coupled unknown k
  double gamma = 0;

  StructuredSolver(bool bristle_tyres, bool brake_stick) {
    for (int k = 0; k < kNumDynamic; ++k) coupled_state[n_coupled++] = structure::kV + k;
    if (bristle_tyres)
      for (int k = 0; k < 2 * kNumWheels; ++k) coupled_state[n_coupled++] = StateIndex::kTyre + k;
    if (brake_stick)
      for (int k = 0; k < 2; ++k) coupled_state[n_coupled++] = StateIndex::kBrakeStick + k;
  }

  static StructuredSolver& of(SUNLinearSolver S) { return *static_cast<StructuredSolver*>(S->content); }

  static int setup(SUNLinearSolver S, SUNMatrix A) {
    using namespace structure;
    StructuredSolver& me = of(S);
    const DenseJacobian& a = dense(A);
    me.gamma = -a(kQ, kV);
    bool finite = std::isfinite(me.gamma);
    for (int d = 0; d < kNumDriven; ++d) {
      const Eigen::Matrix3d F = a.block<3, 3>(kF + 3 * d, kF + 3 * d);
      finite &= F.allFinite();
      me.filters[d].compute(F);
    }
    finite &= a(kL, kL) != 0 && a(kL + 1, kL + 1) != 0;
    const int n = me.n_coupled;
    for (int k = 0; k < n; ++k) {
      const int i = me.coupled_state[k];
      for (int l = 0; l < n; ++l) {
        const int j = me.coupled_state[l];
        me.coupled.at(k, l) = a(i, j) + (l < kNumDynamic ? me.gamma * a(i, kQ + l) : 0.0);
      }
    }
    return finite && me.coupled.factorise(n) ? 0 : 1;
  }

  static int solve(SUNLinearSolver S, SUNMatrix A, N_Vector xv, N_Vector bv, sunrealtype) {
    using namespace structure;
    StructuredSolver& me = of(S);
    const DenseJacobian& a = dense(A);
    const Eigen::Map<const StateVector> b(N_VGetArrayPointer(bv));
    Eigen::Map<StateVector> x(N_VGetArrayPointer(xv));
    StateVector sol = b;  // the states outside the coupled system that nothing moves: A's rows are I
    for (int d = 0; d < kNumDriven; ++d)
      sol.segment<3>(kF + 3 * d) = me.filters[d].solve(b.segment<3>(kF + 3 * d));
    sol[kL] = b[kL] / a(kL, kL);
    sol[kL + 1] = b[kL + 1] / a(kL + 1, kL + 1);
    const int n = me.n_coupled;
    std::array<double, kMaxCoupled> c;
    for (int k = 0; k < n; ++k) {
      const int i = me.coupled_state[k];
      double v = b[i];
      for (int j = 0; j < kNumDynamic; ++j) v -= a(i, kQ + j) * b[kQ + j];
      for (int j = kF; j < kL + kNL; ++j) v -= a(i, j) * sol[j];
      c[k] = v;
    }
    me.coupled.solve(c.data());
    for (int k = 0; k < n; ++k) sol[me.coupled_state[k]] = c[k];
    for (int j = 0; j < kNumDynamic; ++j) sol[kQ + j] = b[kQ + j] + me.gamma * c[j];
    x = sol;
    return sol.allFinite() ? 0 : 1;
  }

  static SUNLinearSolver create(SUNContext ctx, bool bristle_tyres, bool brake_stick) {
    SUNLinearSolver S = SUNLinSolNewEmpty(ctx);
    if (!S) return nullptr;
    S->content = new StructuredSolver(bristle_tyres, brake_stick);
    S->ops->gettype = [](SUNLinearSolver) { return SUNLINEARSOLVER_DIRECT; };
    S->ops->getid = [](SUNLinearSolver) { return SUNLINEARSOLVER_CUSTOM; };
    S->ops->setup = &StructuredSolver::setup;
    S->ops->solve = &StructuredSolver::solve;
    S->ops->free = [](SUNLinearSolver S) {
      delete &of(S);
      S->content = nullptr;
      SUNLinSolFreeEmpty(S);
      return 0;
    };
    return S;
  }
};

}  // namespace

struct Simulation::Impl {
  TruckDynamics dynamics;
  IntegratorOptions options;
  double t;
  StateVector x;
  DriverInputs held{};
  InputSchedule schedule;
  IntegratorStats rk4_stats;
  long failed_rhs = 0;
  long jac_rhs_evals = 0;  // our Jacobian's evaluations, which CVODE does not count
  static constexpr double kTickRegime_s = 0.01;  // landings this close together are a real-time loop's ticks
  long jacobian_every_ = 51;                      // CVODE's msbj
  StateVector scale = tolerance_scale();

  SUNContext ctx = nullptr;
  N_Vector y = nullptr, atol = nullptr, dky = nullptr;
  void* mem = nullptr;
  SUNMatrix A = nullptr;
  SUNLinearSolver LS = nullptr;

  // The load on the forks as a body of its own (load_on_forks.h): what it is while it is there,
  // how it sits now, and the forces on the truck besides its push (the scene's).
  std::optional<LoadOnForksModel> load_model;
  LoadOnForks load_state;
  double load_t;
  std::vector<ExternalForce> scene_forces;
  // The outputs the load's step evaluated, while state, inputs, forces and load are still theirs:
  // outputs() then costs nothing more (a session asks for them every tick).
  Outputs cached_out;
  bool cached = false;

  Impl(const TruckDynamics& d, const StateVector& x0, IntegratorOptions o, double t0)
      : dynamics(d), options(o), t(t0), x(x0), load_t(t0) {
    if (!x0.allFinite()) throw std::invalid_argument("initial state is not finite");
    scene_forces = dynamics.environment().external_forces;
    dynamics.environment().external_forces.reserve(scene_forces.size() + 8);
    if (dynamics.load()) put_on(*dynamics.load());
    if (options.kind == IntegratorKind::kRk4) {
      if (!(options.rk4_step_s > 0)) throw std::invalid_argument("rk4 step must be positive");
      return;
    }
    if (!(options.rtol > 0 && options.rtol < 1)) throw std::invalid_argument("rtol must be in (0, 1)");
    if (SUNContext_Create(nullptr, &ctx) != 0) throw std::runtime_error("SUNContext_Create failed");
    y = N_VNew_Serial(StateIndex::kSize, ctx);
    atol = N_VNew_Serial(StateIndex::kSize, ctx);
    if (!y || !atol) throw std::runtime_error("N_VNew_Serial failed");
    use_fixed_size_operations(y);
    use_fixed_size_operations(atol);
    Eigen::Map<StateVector>(N_VGetArrayPointer(y)) = x;
    Eigen::Map<StateVector>(N_VGetArrayPointer(atol)) = options.rtol * tolerance_scale();
    if (options.kind == IntegratorKind::kCvodeBdf) {
      mem = CVodeCreate(CV_BDF, ctx);
      A = make_matrix(ctx);
      LS = StructuredSolver::create(ctx, bristle_tyres(d.truck()), brake_sticks(d.truck()));
      if (!mem || !A || !LS || CVodeInit(mem, &Impl::rhs, t, y) != CV_SUCCESS ||
          CVodeSVtolerances(mem, options.rtol, atol) != CV_SUCCESS ||
          CVodeSetLinearSolver(mem, LS, A) != CV_SUCCESS || CVodeSetUserData(mem, this) != CV_SUCCESS ||
          CVodeSetJacFn(mem, &Impl::jacobian) != CV_SUCCESS ||
          CVodeSetMaxNumSteps(mem, 10'000'000) != CV_SUCCESS)  // default 500 per call is too few
        throw std::runtime_error("CVODE set-up failed");
      if (CVodeSetMaxOrd(mem, options.cvode_max_order) != CV_SUCCESS)
        throw std::invalid_argument("CVODE max order must be 1-5");
    } else {
      mem = ERKStepCreate(&Impl::rhs, t, y, ctx);
      if (!mem || ERKStepSetTableNum(mem, ARKODE_DORMAND_PRINCE_7_4_5) != ARK_SUCCESS ||
          ERKStepSVtolerances(mem, options.rtol, atol) != ARK_SUCCESS ||
          ERKStepSetUserData(mem, this) != ARK_SUCCESS ||
          ERKStepSetMaxNumSteps(mem, 100'000'000) != ARK_SUCCESS)
        throw std::runtime_error("ARKODE ERKStep set-up failed");
    }
  }

  ~Impl() {
    if (options.kind == IntegratorKind::kCvodeBdf) CVodeFree(&mem);
    else if (mem) ERKStepFree(&mem);
    if (LS) SUNLinSolFree(LS);
    if (A) SUNMatDestroy(A);
    if (y) N_VDestroy(y);
    if (atol) N_VDestroy(atol);
    if (dky) N_VDestroy(dky);
    if (ctx) SUNContext_Free(&ctx);
  }

  DriverInputs inputs_at(double time) const { return schedule ? schedule(time) : held; }

  // The right-hand side for SUNDIALS; a positive return asks it to retry with a smaller step.
  static int rhs(sunrealtype time, N_Vector yv, N_Vector ydot, void* user) {
    Impl* self = static_cast<Impl*>(user);
    const Eigen::Map<const StateVector> xs(N_VGetArrayPointer(yv));
    Eigen::Map<StateVector> dx(N_VGetArrayPointer(ydot));
    StateVector d;
    if (!self->dynamics.derivative(xs, self->inputs_at(time), d)) {
      ++self->failed_rhs;
      return 1;
    }
    dx = d;
    return 0;
  }

  // The Jacobian by differences, column by column, but only where the model is not known: the
  // q rows are exactly [0, I, 0] (the structured solver relies on it), and the wheels' spin angles
  // (round wheels, inertia symmetric about the axle) and the states a truck does not use
  // (bristles of a paper tyre, brake bristles of a brake without stick) have zero columns. So
  // do x and y on flat ground with nothing fixed in the world acting on the truck (no scene
  // forces at world points, no chocks): every force is taken about the chassis CoG, so moving
  // the truck over a level floor changes nothing but rounding (differences of 1e-8 beside 1e3).
  static int jacobian(sunrealtype time, N_Vector yv, N_Vector fyv, SUNMatrix J, void* user, N_Vector, N_Vector,
                      N_Vector) {
    Impl* self = static_cast<Impl*>(user);
    const Eigen::Map<const StateVector> y(N_VGetArrayPointer(yv)), fy(N_VGetArrayPointer(fyv));
    const DriverInputs u = self->inputs_at(time);
    const TruckParams& truck = self->dynamics.truck();
    const bool bristle = bristle_tyres(truck), stick = brake_sticks(truck);
    const Environment& env = self->dynamics.environment();
    const bool level = env.ground.flat() && env.external_forces.empty() && !env.chock_anchors_m;
    DenseJacobian& jac = dense(J);
    jac.setZero();
    StateVector x = y, d;
    const auto step = [&](int j) { return 1.5e-8 * std::max(std::abs(y[j]), self->scale[j]); };
    const auto accel = [](int j) { return j >= StateIndex::kDriven && j < StateIndex::kTorque && (j - StateIndex::kDriven) % 3 == 2; };
    // The driven accelerations z'': q-dot's rows from the model (q'' is linear in z''), each
    // filter's rows from one evaluation with every z'' stepped (a filter answers its own alone,
    // nothing else reads z''): one evaluation and one of the mass matrix alone, where
    // differences took four evaluations.
    {
      Eigen::Matrix<double, kNumDynamic, kNumDriven> coupling;
      if (!self->dynamics.driven_coupling(y, coupling)) return 1;
      std::array<double, kNumDriven> hz;
      for (int k = 0; k < kNumDriven; ++k) {
        const int j = StateIndex::kDriven + 3 * k + 2;
        x[j] = y[j] + step(j);
        hz[k] = x[j] - y[j];
      }
      const bool ok = self->dynamics.derivative(x, u, d);
      x = y;
      ++self->jac_rhs_evals;
      if (!ok) return 1;
      for (int k = 0; k < kNumDriven; ++k) {
        const int j = StateIndex::kDriven + 3 * k + 2, f = StateIndex::kDriven + 3 * k;
        jac.block<kNumDynamic, 1>(StateIndex::kQdot, j) = coupling.col(k);
        jac.block<3, 1>(f, j) = (d - fy).segment<3>(f) / hz[k];
      }
    }
    for (int j = 0; j < StateIndex::kSize; ++j) {
      auto col = jac.col(j);
      const bool rate = j >= StateIndex::kQdot && j < StateIndex::kQdot + kNumDynamic;
      if (rate) col[j - StateIndex::kQdot] = 1;
      if (accel(j)) continue;
      if (!bristle && j >= StateIndex::kTyre && j < StateIndex::kTyre + 2 * kNumWheels) continue;
      if (j >= StateIndex::kQ + kAvr1 && j <= StateIndex::kQ + kAvr3) continue;  // a wheel is round: its angle is no force
      if (!stick && j >= StateIndex::kBrakeStick) continue;
      if (level && (j == StateIndex::kQ + kX || j == StateIndex::kQ + kY)) continue;
      x[j] = y[j] + step(j);
      const double hj = x[j] - y[j];  // the step as represented
      const bool ok = self->dynamics.derivative(x, u, d);
      x[j] = y[j];
      ++self->jac_rhs_evals;
      if (!ok) return 1;
      col.tail<StateIndex::kSize - kNumDynamic>() = (d - fy).tail<StateIndex::kSize - kNumDynamic>() / hj;
    }
    return 0;
  }

  StateVector f(double time, const StateVector& s) {
    StateVector d;
    ++rk4_stats.rhs_evals;
    if (!dynamics.derivative(s, inputs_at(time), d))
      throw IntegratorError("rk4: non-finite derivative at t = " + std::to_string(time));
    return d;
  }

  void rk4_step(double h) {
    const StateVector k1 = f(t, x);
    const StateVector k2 = f(t + 0.5 * h, x + 0.5 * h * k1);
    const StateVector k3 = f(t + 0.5 * h, x + 0.5 * h * k2);
    const StateVector k4 = f(t + h, x + h * k3);
    x += h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
    t += h;
    ++rk4_stats.steps;
  }

  void advance_to(double tout, double horizon) {
    if (!(tout >= t)) throw std::invalid_argument("advance_to: time must not go backwards");
    if (std::isnan(horizon)) horizon = tout;
    if (!(horizon >= tout)) throw std::invalid_argument("advance_to: horizon before the target time");
    if (tout == t) return;
    if (options.kind == IntegratorKind::kRk4) {
      const double h = options.rk4_step_s;
      // Whole steps; a final short step lands exactly on tout (rounding slack of 1e-9 h).
      while (tout - t > 1e-9 * h) rk4_step(std::min(h, tout - t));
      t = tout;
      return;
    }
    double tret = t;
    int flag;
    if (options.kind == IntegratorKind::kCvodeBdf) {
      // Landing on every tick of a real-time loop caps the steps at the tick, where gamma = h beta
      // is small and I - gamma J tolerates an older J: rebuilt every 51 steps (CVODE's default) it
      // put 2% of 1 ms ticks at 60-100 us. Every 200 steps (0.2 s), or after a convergence
      // failure, a third fewer evaluations. (Every 1000 was cheaper still, but moved the worker's
      // path enough that the shipped clean exam script, driven open loop, left its route.)
      const long jacobian_every = horizon == tout && tout - t <= kTickRegime_s ? 200 : 51;
      if (jacobian_every != jacobian_every_) {
        CVodeSetJacEvalFrequency(mem, jacobian_every);
        jacobian_every_ = jacobian_every;
      }
      CVodeSetStopTime(mem, horizon);
      flag = CVode(mem, tout, y, &tret, CV_NORMAL);
    } else {
      ERKStepSetStopTime(mem, horizon);
      flag = ERKStepEvolve(mem, tout, y, &tret, ARK_NORMAL);
    }
    if (flag < 0)
      throw IntegratorError(std::string(integrator_name(options.kind)) + " failed at t = " +
                            std::to_string(tret) + " (flag " + std::to_string(flag) + ")");
    t = tret;
    x = Eigen::Map<const StateVector>(N_VGetArrayPointer(y));
  }

  // One step of the variable-step integrator toward `horizon`, never past it. `first_output` is
  // where a caller would first have asked for the state: CVODE sizes its first step by it, as
  // advance_to's first target would.
  void step_toward(double horizon, double first_output) {
    if (!(horizon > t)) throw std::invalid_argument("step_toward: horizon not after the current time");
    double tret = t;
    int flag;
    if (options.kind == IntegratorKind::kCvodeBdf) {
      if (jacobian_every_ != 51) {
        CVodeSetJacEvalFrequency(mem, 51);
        jacobian_every_ = 51;
      }
      CVodeSetStopTime(mem, horizon);
      flag = CVode(mem, first_output, y, &tret, CV_ONE_STEP);
    } else if (options.kind == IntegratorKind::kDopri5) {
      ERKStepSetStopTime(mem, horizon);
      flag = ERKStepEvolve(mem, first_output, y, &tret, ARK_ONE_STEP);
    } else {
      throw std::invalid_argument("step_toward: rk4 has no steps of its own to interpolate");
    }
    if (flag < 0)
      throw IntegratorError(std::string(integrator_name(options.kind)) + " failed at t = " +
                            std::to_string(tret) + " (flag " + std::to_string(flag) + ")");
    t = tret;
    x = Eigen::Map<const StateVector>(N_VGetArrayPointer(y));
  }

  // The state at `time` within the last step, by the integrator's own interpolation (what
  // advance_to returns for a target it stepped past).
  StateVector state_at(double time) {
    if (!dky) {
      dky = N_VNew_Serial(StateIndex::kSize, ctx);
      if (!dky) throw std::runtime_error("N_VNew_Serial failed");
    }
    const int flag = options.kind == IntegratorKind::kCvodeBdf ? CVodeGetDky(mem, time, 0, dky)
                                                               : ERKStepGetDky(mem, time, 0, dky);
    if (flag < 0) throw std::invalid_argument("state_at: time " + std::to_string(time) + " is outside the last step");
    return Eigen::Map<const StateVector>(N_VGetArrayPointer(dky));
  }

  void put_on(const Load& load) {
    load_model = load_on_forks_model(dynamics.truck(), load);
    load_state = LoadOnForks{};
    load_state.phase = LoadPhase::kStuck;
    load_t = t;
  }

  // The truck's external forces: the scene's, and a sliding load's push on the forks.
  void gather_forces() {
    std::vector<ExternalForce>& f = dynamics.environment().external_forces;
    f.assign(scene_forces.begin(), scene_forces.end());
    if (load_state.phase == LoadPhase::kSliding) f.push_back(load_state.push);
  }

  // The load's step after the truck's, at the tick's end: it sticks, slips or falls, and the truck's
  // model takes it into its mass matrix or out of it (a restart, as any load change).
  void step_the_load() {
    const double dt = t - load_t;
    load_t = t;
    if (!load_model || dt <= 0) return;
    if (load_state.phase != LoadPhase::kStuck && load_state.phase != LoadPhase::kSliding) return;
    // Welded (the paper's model): it only leaves the forks when the truck goes over.
    if (dynamics.truck().load_contact.welded() && !truck_gone_over(coordinates(x), load_model->tipped_over_rad)) return;
    StateVector dx;
    if (!dynamics.derivative(x, inputs_at(t), dx, &cached_out)) return;  // the integrator reports it
    const LoadChangeInModel change = step_load(*load_model, load_state, cached_out, dynamics.environment().gravity_m_s2, dt);
    // A sliding load's push changes the forces, and a load moved or gone the mass matrix.
    cached = change == LoadChangeInModel::kNone && load_state.phase == LoadPhase::kStuck;
    if (load_state.phase == LoadPhase::kFallen) load_model.reset();
    if (change == LoadChangeInModel::kAttach) dynamics.attach_load(load_at(*load_model, load_state));
    if (change == LoadChangeInModel::kRelease) dynamics.release_load();
    gather_forces();
    if (change != LoadChangeInModel::kNone) restart();
  }

  // After a change the integrator's history no longer describes (load attached or released).
  void restart() {
    if (options.kind == IntegratorKind::kRk4) return;
    Eigen::Map<StateVector>(N_VGetArrayPointer(y)) = x;
    if (options.kind == IntegratorKind::kCvodeBdf) CVodeReInit(mem, t, y);
    else ERKStepReInit(mem, &Impl::rhs, t, y);
  }

  IntegratorStats stats() const {
    if (options.kind == IntegratorKind::kRk4) return rk4_stats;
    IntegratorStats s;
    long nst = 0, nfe = 0, nfels = 0;
    if (options.kind == IntegratorKind::kCvodeBdf) {
      CVodeGetNumSteps(mem, &nst);
      CVodeGetNumRhsEvals(mem, &nfe);
      CVodeGetNumLinRhsEvals(mem, &nfels);
    } else {
      ERKStepGetNumSteps(mem, &nst);
      ERKStepGetNumRhsEvals(mem, &nfe);
    }
    s.steps = nst;
    s.rhs_evals = nfe + nfels + jac_rhs_evals;
    return s;
  }
};

Simulation::Simulation(const TruckDynamics& dynamics, const StateVector& x0, IntegratorOptions options, double t0)
    : impl_(std::make_unique<Impl>(dynamics, x0, options, t0)) {}
Simulation::~Simulation() = default;

void Simulation::set_inputs(const DriverInputs& u) {
  impl_->schedule = nullptr;
  impl_->held = u;
  impl_->cached = false;
}
void Simulation::set_input_schedule(InputSchedule schedule) {
  impl_->schedule = std::move(schedule);
  impl_->cached = false;
}
void Simulation::advance_to(double t, double horizon) {
  if (t != impl_->t) impl_->cached = false;
  impl_->advance_to(t, horizon);
  impl_->step_the_load();
}
void Simulation::step_toward(double horizon, double first_output) {
  impl_->cached = false;
  impl_->step_toward(horizon, first_output);
  impl_->step_the_load();
}
StateVector Simulation::state_at(double t) { return impl_->state_at(t); }
double Simulation::time() const { return impl_->t; }
const StateVector& Simulation::state() const { return impl_->x; }

Outputs Simulation::outputs_at(double t, const StateVector& x) const {
  Outputs out;
  StateVector dx;
  impl_->dynamics.derivative(x, impl_->inputs_at(t), dx, &out);
  return out;
}

Outputs Simulation::outputs() const {
  if (impl_->cached) return impl_->cached_out;
  return outputs_at(impl_->t, impl_->x);
}

void Simulation::set_external_forces(const std::vector<ExternalForce>& forces) {
  const std::vector<ExternalForce>& held = impl_->scene_forces;
  const bool same = forces.size() == held.size() &&
                    std::equal(forces.begin(), forces.end(), held.begin(), [](const ExternalForce& a, const ExternalForce& b) {
                      return a.body == b.body && a.point_m == b.point_m && a.force_N == b.force_N;
                    });
  if (same) return;
  impl_->cached = false;
  impl_->scene_forces.assign(forces.begin(), forces.end());
  impl_->gather_forces();
}
void Simulation::set_grip_patches_absent(uint64_t absent) {
  uint64_t& held = impl_->dynamics.environment().grip_patches_absent;
  if (held == absent) return;
  impl_->cached = false;
  held = absent;
}
void Simulation::attach_load(const Load& load) {
  impl_->cached = false;
  impl_->dynamics.attach_load(load);
  impl_->put_on(load);
  impl_->gather_forces();
  impl_->restart();
}
void Simulation::release_load() {
  impl_->cached = false;
  impl_->dynamics.release_load();
  impl_->load_model.reset();
  impl_->load_state = LoadOnForks{};
  impl_->gather_forces();
  impl_->restart();
}
const Load* Simulation::load() const { return impl_->load_model ? &impl_->load_model->load : nullptr; }
const LoadOnForks& Simulation::load_on_forks() const { return impl_->load_state; }
void Simulation::set_load_on_forks(const LoadOnForks& state) {
  Impl& s = *impl_;
  s.cached = false;
  s.load_state = state;
  s.load_t = s.t;
  if (!s.load_model || (state.phase != LoadPhase::kStuck && state.phase != LoadPhase::kSliding)) {
    s.load_model.reset();
    s.dynamics.release_load();
  } else {
    s.dynamics.attach_load(load_at(*s.load_model, state));
  }
  s.gather_forces();
  s.restart();
}
const TruckDynamics& Simulation::dynamics() const { return impl_->dynamics; }
IntegratorStats Simulation::stats() const { return impl_->stats(); }
const IntegratorOptions& Simulation::options() const { return impl_->options; }

}  // namespace forklift
