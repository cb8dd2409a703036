// Integrator back ends behind Simulation. SUNDIALS 6.4 C API: every object takes a SUNContext.
#include "forklift/dynamics/simulation.h"

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

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
      A = SUNDenseMatrix(StateIndex::kSize, StateIndex::kSize, ctx);
      LS = SUNLinSol_Dense(y, A, ctx);
      if (!mem || !A || !LS || CVodeInit(mem, &Impl::rhs, t, y) != CV_SUCCESS ||
          CVodeSVtolerances(mem, options.rtol, atol) != CV_SUCCESS ||
          CVodeSetLinearSolver(mem, LS, A) != CV_SUCCESS || CVodeSetUserData(mem, this) != CV_SUCCESS ||
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
    s.rhs_evals = nfe + nfels;
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
