// A running simulation: the dynamics, the state, the time, the inputs, and an integrator chosen
// at run time (section 12): CVODE BDF (default; the paper concludes an implicit method is
// needed), ARKODE explicit Dormand-Prince (the paper's ode45), or fixed-step RK4 (its rk4).
#pragma once

#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

#include "forklift/dynamics/dynamics.h"
#include "forklift/dynamics/load_on_forks.h"

namespace forklift {

enum class IntegratorKind { kCvodeBdf, kDopri5, kRk4 };
// "cvode", "dopri5", "rk4"; throws std::invalid_argument for anything else.
IntegratorKind parse_integrator(const std::string& name);
const char* integrator_name(IntegratorKind kind);

struct IntegratorOptions {
  IntegratorKind kind = IntegratorKind::kCvodeBdf;
  // Variable-step methods; absolute tolerances scale with it per state component. 3e-4 keeps
  // manoeuvre 4's final position within 1 cm of an rtol 1e-10 run (bench/).
  double rtol = 3e-4;
  // BDF order cap. The truck's body modes (heave, pitch, roll near 5 Hz, damping ratio about
  // 0.02) lie close to the imaginary axis, where BDF3-5 are not stable and CVODE must take
  // small steps; BDF2 is A-stable and needed about half the steps on manoeuvres 4 and 17.
  int cvode_max_order = 2;
  double rk4_step_s = 1e-3;
};

struct IntegratorStats {
  long steps = 0;
  // Every evaluation of the derivative, including finite-difference Jacobians (not counted: the
  // Jacobian's mass-matrix-only evaluation for TruckDynamics::driven_coupling, one per Jacobian).
  long rhs_evals = 0;
};

// Numerical trouble the integrator could not get past (non-finite state, repeated failures).
class IntegratorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Inputs as a function of sim time, for scripted runs (the paper's manoeuvres).
using InputSchedule = std::function<DriverInputs(double t)>;

class Simulation {
 public:
  Simulation(const TruckDynamics& dynamics, const StateVector& x0, IntegratorOptions options,
             double t0 = 0);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // Inputs held constant from now on (a real-time loop sets them at each exact landing).
  void set_inputs(const DriverInputs& u);
  void set_input_schedule(InputSchedule schedule);

  // Integrates to time t >= time(). A variable-step integrator may step beyond t and interpolate
  // back (fewer steps, for sampling output) but never beyond `horizon` (>= t), where the inputs
  // or the load may change; by default it lands exactly on t. Throws IntegratorError on
  // numerical failure; the state is then the last good one.
  void advance_to(double t, double horizon = NAN);

  // For a caller that samples a run itself, outside the integrator's own time (the manoeuvres):
  // one step of the variable-step integrator toward `horizon`, never past it (the load then
  // steps as after advance_to), and the state at any time within that step by the integrator's
  // interpolation. `first_output` sizes CVODE's first step as advance_to's first target would.
  // Not for rk4, whose steps have no interpolant.
  void step_toward(double horizon, double first_output);
  StateVector state_at(double t);

  double time() const;
  const StateVector& state() const;
  Outputs outputs() const;  // evaluated at the current state and inputs
  Outputs outputs_at(double t, const StateVector& x) const;  // at state x and the inputs of time t

  // The scene's push-back on the truck, held until changed (Environment::external_forces).
  void set_external_forces(const std::vector<ExternalForce>& forces);
  // The grip patches not on the floor, held until changed (Environment::grip_patches_absent).
  void set_grip_patches_absent(uint64_t absent);

  // Section 5, at run time: change the carriage's mass and restart the integrator's history.
  // A load put on the forks is a body of its own there (load_on_forks.h): after each advance_to
  // it sticks, slides along the forks or falls off them, as friction and the truck's motion say
  // (welded where the truck file gives no load_contact); the truck's model follows.
  void attach_load(const Load& load);
  void release_load();
  // The load as put on the forks (nullptr: none, or it has fallen), and how it sits there now.
  const Load* load() const;
  const LoadOnForks& load_on_forks() const;
  // Back to a copied state of the load on the attached load (a rewind); restarts the integrator.
  void set_load_on_forks(const LoadOnForks& state);
  const TruckDynamics& dynamics() const;
  IntegratorStats stats() const;
  const IntegratorOptions& options() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace forklift
