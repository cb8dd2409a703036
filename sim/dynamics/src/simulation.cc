// Integrator back ends behind Simulation. SUNDIALS 6.4 C API: every object takes a SUNContext.
#include "forklift/dynamics/simulation.h"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>

#include <Eigen/LU>
#include <cmath>

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

// The Newton matrix A = I - gamma J of CVODE has the model's structure (issue 19, item 3):
// - q' = q-dot exactly, so the q rows of A are [I, -gamma I, 0];
// - each driven coordinate's filter depends on the filters alone, the drive and brake lags on
//   themselves alone;
// - q-dot, the tyre bristles and the brake bristles (17 states) depend on everything.
// So the filters (12) and lags (2) are solved on their own, q is eliminated (dq = b_q + gamma
// dv), and only a 17x17 system is factorised, where SUNDIALS' dense solver factorised all 40.
namespace structure {
constexpr int kQ = StateIndex::kQ, kV = StateIndex::kQdot, kF = StateIndex::kDriven, kNF = 3 * kNumDriven;
constexpr int kL = StateIndex::kTorque, kNL = 2;
constexpr int kNC = kNumDynamic + 2 * kNumWheels + 2;  // q-dot, tyre bristles, brake bristles
// State index of coupled unknown k.
constexpr int coupled_state(int k) { return k < kNumDynamic ? kV + k : StateIndex::kTyre + (k - kNumDynamic); }
static_assert(StateIndex::kTyre + 2 * kNumWheels + 2 == StateIndex::kSize, "tyre and brake bristles end the state");
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

struct StructuredSolver {
  Eigen::PartialPivLU<Eigen::Matrix<double, structure::kNF, structure::kNF>> filters;
  Eigen::PartialPivLU<Eigen::Matrix<double, structure::kNL, structure::kNL>> lags;
  Eigen::PartialPivLU<Eigen::Matrix<double, structure::kNC, structure::kNC>> coupled;
  double gamma = 0;

  static StructuredSolver& of(SUNLinearSolver S) { return *static_cast<StructuredSolver*>(S->content); }

  static int setup(SUNLinearSolver S, SUNMatrix A) {
    using namespace structure;
    StructuredSolver& me = of(S);
    const DenseJacobian& a = dense(A);
    me.gamma = -a(kQ, kV);
    const Eigen::Matrix<double, kNF, kNF> F = a.block<kNF, kNF>(kF, kF);
    const Eigen::Matrix<double, kNL, kNL> L = a.block<kNL, kNL>(kL, kL);
    Eigen::Matrix<double, kNC, kNC> C;
    for (int k = 0; k < kNC; ++k)
      for (int l = 0; l < kNC; ++l) {
        const int i = coupled_state(k), j = coupled_state(l);
        C(k, l) = a(i, j) + (l < kNumDynamic ? me.gamma * a(i, kQ + l) : 0.0);
      }
    me.filters.compute(F);
    me.lags.compute(L);
    me.coupled.compute(C);
    const bool finite = F.allFinite() && L.allFinite() && C.allFinite();
    return finite ? 0 : 1;
  }

  static int solve(SUNLinearSolver S, SUNMatrix A, N_Vector xv, N_Vector bv, sunrealtype) {
    using namespace structure;
    StructuredSolver& me = of(S);
    const DenseJacobian& a = dense(A);
    const Eigen::Map<const StateVector> b(N_VGetArrayPointer(bv));
    Eigen::Map<StateVector> x(N_VGetArrayPointer(xv));
    StateVector sol;
    sol.segment<kNF>(kF) = me.filters.solve(b.segment<kNF>(kF));
    sol.segment<kNL>(kL) = me.lags.solve(b.segment<kNL>(kL));
    Eigen::Matrix<double, kNC, 1> r;
    for (int k = 0; k < kNC; ++k) {
      const int i = coupled_state(k);
      double v = b[i];
      for (int j = 0; j < kNumDynamic; ++j) v -= a(i, kQ + j) * b[kQ + j];
      for (int j = kF; j < kF + kNF + kNL; ++j) v -= a(i, j) * sol[j];
      r[k] = v;
    }
    const Eigen::Matrix<double, kNC, 1> c = me.coupled.solve(r);
    for (int k = 0; k < kNC; ++k) sol[coupled_state(k)] = c[k];
    sol.segment<kNumDynamic>(kQ) = b.segment<kNumDynamic>(kQ) + me.gamma * c.head<kNumDynamic>();
    x = sol;
    return sol.allFinite() ? 0 : 1;
  }

  static SUNLinearSolver create(SUNContext ctx) {
    SUNLinearSolver S = SUNLinSolNewEmpty(ctx);
    if (!S) return nullptr;
    S->content = new StructuredSolver;
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
  N_Vector y = nullptr, atol = nullptr;
  void* mem = nullptr;
  SUNMatrix A = nullptr;
  SUNLinearSolver LS = nullptr;

  Impl(const TruckDynamics& d, const StateVector& x0, IntegratorOptions o, double t0)
      : dynamics(d), options(o), t(t0), x(x0) {
    if (!x0.allFinite()) throw std::invalid_argument("initial state is not finite");
    if (options.kind == IntegratorKind::kRk4) {
      if (!(options.rk4_step_s > 0)) throw std::invalid_argument("rk4 step must be positive");
      return;
    }
    if (!(options.rtol > 0 && options.rtol < 1)) throw std::invalid_argument("rtol must be in (0, 1)");
    if (SUNContext_Create(nullptr, &ctx) != 0) throw std::runtime_error("SUNContext_Create failed");
    y = N_VNew_Serial(StateIndex::kSize, ctx);
    atol = N_VNew_Serial(StateIndex::kSize, ctx);
    Eigen::Map<StateVector>(N_VGetArrayPointer(y)) = x;
    Eigen::Map<StateVector>(N_VGetArrayPointer(atol)) = options.rtol * tolerance_scale();
    if (options.kind == IntegratorKind::kCvodeBdf) {
      mem = CVodeCreate(CV_BDF, ctx);
      A = make_matrix(ctx);
      LS = StructuredSolver::create(ctx);
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
  // (bristles of a paper tyre, brake bristles of a brake without stick) have zero columns.
  static int jacobian(sunrealtype time, N_Vector yv, N_Vector fyv, SUNMatrix J, void* user, N_Vector, N_Vector,
                      N_Vector) {
    Impl* self = static_cast<Impl*>(user);
    const Eigen::Map<const StateVector> y(N_VGetArrayPointer(yv)), fy(N_VGetArrayPointer(fyv));
    const DriverInputs u = self->inputs_at(time);
    const TruckParams& truck = self->dynamics.truck();
    const bool bristle = truck.contact.tyre == TyreModel::kBristle;
    const bool stick = truck.drive.brake_stick_angle_rad > 0;
    DenseJacobian& jac = dense(J);
    jac.setZero();
    StateVector x = y, d;
    for (int j = 0; j < StateIndex::kSize; ++j) {
      auto col = jac.col(j);
      const bool rate = j >= StateIndex::kQdot && j < StateIndex::kQdot + kNumDynamic;
      if (rate) col[j - StateIndex::kQdot] = 1;
      if (!bristle && j >= StateIndex::kTyre && j < StateIndex::kTyre + 2 * kNumWheels) continue;
      if (j >= StateIndex::kQ + kAvr1 && j <= StateIndex::kQ + kAvr3) continue;  // a wheel is round: its angle is no force
      if (!stick && j >= StateIndex::kBrakeStick) continue;
      const double h = 1.5e-8 * std::max(std::abs(y[j]), self->scale[j]);
      x[j] = y[j] + h;
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
}
void Simulation::set_input_schedule(InputSchedule schedule) { impl_->schedule = std::move(schedule); }
void Simulation::advance_to(double t, double horizon) { impl_->advance_to(t, horizon); }
double Simulation::time() const { return impl_->t; }
const StateVector& Simulation::state() const { return impl_->x; }

Outputs Simulation::outputs() const {
  Outputs out;
  StateVector dx;
  impl_->dynamics.derivative(impl_->x, impl_->inputs_at(impl_->t), dx, &out);
  return out;
}

void Simulation::set_external_forces(const std::vector<ExternalForce>& forces) {
  impl_->dynamics.environment().external_forces = forces;
}
void Simulation::attach_load(const Load& load) {
  impl_->dynamics.attach_load(load);
  impl_->restart();
}
void Simulation::release_load() {
  impl_->dynamics.release_load();
  impl_->restart();
}
const TruckDynamics& Simulation::dynamics() const { return impl_->dynamics; }
IntegratorStats Simulation::stats() const { return impl_->stats(); }
const IntegratorOptions& Simulation::options() const { return impl_->options; }

}  // namespace forklift
