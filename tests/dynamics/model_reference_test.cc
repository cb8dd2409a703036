// The model pinned to a stored reference: states sampled along manoeuvres 4 and 17 on
// both shipped trucks, and a set of harder states (laden on a ramp, tipped onto the body, on a
// tilt table with chocks, pushed by the scene), each with the derivative, M, Q, the driven forces
// and the applied power the model gave when the file was written. Any reformulation of the
// equations (a faster mass matrix, a cheaper force pass) must reproduce them within 1e-12.
//
// Scales, so that metres, radians, tonnes and a wheel's spin inertia weigh alike (as in
// multibody_test.cc), with s_i = sqrt(M_ii) of the reference:
//   M:            |dM_ij| / (s_i s_j)                       <= 1e-12
//   Q:            |dQ_i| / s_i  over  max_i |Q_i| / s_i     <= 1e-12
//   q'' (dx):     |dq''_i| s_i  over  max_i |q''_i| s_i, or the forces' max_i |Q_i| / s_i
//                 if larger (at rest q'' is a small difference of balanced forces) <= 1e-12
//   other dx:     |d dx_i| over the largest |dx_i| of that component in the case, or a
//                 millionth of its group's largest when the component itself stays near zero
//   driven forces and power: relative to the largest in the sample.
//
// Regenerate (only when the model is meant to change, and say so in the commit):
//   build/tests/model_reference_test --gtest_also_run_disabled_tests --gtest_filter='*Regenerate*'
// writes tests/dynamics/model_reference.json in the source tree.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "forklift/dynamics/manoeuvre.h"
#include "test_truck.h"

using namespace forklift;
using nlohmann::json;

namespace {

using MassMatrix = Eigen::Matrix<double, kNumCoords, kNumCoords>;

const char* const kCases[] = {"m4_paper", "m17_paper", "m4_shipped", "m17_shipped", "hard_shipped"};

const TruckParams& truck_of(const std::string& name) {
  return name.find("paper") != std::string::npos ? paper_truck() : shipped_truck();
}

// The evaluator a case's states belong to: its truck, its load and its environment.
TruckDynamics dynamics_of(const std::string& name) {
  const TruckParams& truck = truck_of(name);
  if (name.rfind("m", 0) == 0) {
    TruckDynamics d(truck);
    const ManoeuvreSpec spec = manoeuvre(name[1] == '4' ? 4 : 17, truck);
    if (spec.load) d.attach_load(*spec.load);
    return d;
  }
  // hard_shipped: a ramp under the truck, a load, and the scene pushing on chassis and forks;
  // states below add tipping, chocks and a tilted gravity on top.
  Environment env;
  Ramp ramp;
  ramp.start_m = Eigen::Vector2d(-1.0, -3.0);
  ramp.heading_rad = 0.3;
  ramp.length_m = 4;
  ramp.width_m = 8;
  ramp.rise_m = 0.4;
  ramp.plateau_m = 3;
  env.ground = Ground({ramp});
  env.external_forces = {{TruckBody::kChassis, {0.3, 0.6, 0.5}, {-800, 300, 50}},
                         {TruckBody::kCarriage, {1.9, -0.2, 1.0}, {-400, -100, 200}},
                         {TruckBody::kMast, {1.5, 0.1, 2.0}, {100, 50, -20}}};
  TruckDynamics d(truck, env);
  d.attach_load(box_load(900, 1.0, 1.0, 1.0, 0.5, 0.15));
  return d;
}

struct Variant {
  bool chocked = false;
  bool tilted = false;
};
Variant variant_of(int k) { return {k % 4 == 1, k % 4 == 2}; }

// The environment of sample k of the hard case (chocks and tilt vary by sample).
void apply_variant(TruckDynamics& d, const std::string& name, int k) {
  if (name != "hard_shipped") return;
  const Variant v = variant_of(k);
  Environment& env = d.environment();
  env.gravity_m_s2 = v.tilted ? Eigen::Vector3d(1.1, -2.3, -9.4) : Eigen::Vector3d(0, 0, -9.81);
  if (v.chocked) {
    env.chock_anchors_m = std::array<Eigen::Vector2d, kNumWheels>{
        Eigen::Vector2d(0.01, 0.46), Eigen::Vector2d(-0.02, -0.44), Eigen::Vector2d(-1.24, 0.01)};
  } else {
    env.chock_anchors_m.reset();
  }
}

struct PinnedState {
  StateVector x;
  DriverInputs u;
};

DriverInputs inputs_from(const json& j) {
  DriverInputs u;
  u.drive_torque_N_m = j[0];
  u.brake_torque_N_m = j[1];
  u.steer_rad = j[2];
  u.tilt_rate_rad_s = j[3];
  u.lift_rate_m_s = j[4];
  u.shift_rate_m_s = j[5];
  u.parking_brake = j[6].get<double>() != 0;
  return u;
}
json inputs_to(const DriverInputs& u) {
  return {u.drive_torque_N_m, u.brake_torque_N_m, u.steer_rad, u.tilt_rate_rad_s, u.lift_rate_m_s, u.shift_rate_m_s,
          u.parking_brake ? 1.0 : 0.0};
}

template <class V>
json vec(const V& v) {
  json a = json::array();
  for (int i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

// States to pin: along a manoeuvre every 2 s (CVODE at its default tolerance; the states are
// stored, so how they were reached does not matter), or hand-made hard states.
std::vector<PinnedState> states_of(const std::string& name) {
  std::vector<PinnedState> out;
  const TruckParams& truck = truck_of(name);
  if (name.rfind("m", 0) == 0) {
    const ManoeuvreSpec spec = manoeuvre(name[1] == '4' ? 4 : 17, truck);
    TruckDynamics d = dynamics_of(name);
    StateVector x0 = d.rest_state(0, 0, 0, 0, 0, spec.lift_m, 0);
    if (!d.settle_static(x0)) throw std::runtime_error("no equilibrium");
    Simulation sim(d, x0, IntegratorOptions{});
    sim.set_input_schedule(spec.inputs);
    out.push_back({sim.state(), spec.inputs(0)});
    for (double t = 1.0; t < 20; t += 2.0) {
      sim.advance_to(t, t < 10 && t + 2 > 10 ? 10.0 : NAN);
      out.push_back({sim.state(), spec.inputs(t)});
    }
    return out;
  }
  std::mt19937 rng(19);
  std::uniform_real_distribution<double> u(-1, 1);
  TruckDynamics d = dynamics_of(name);
  for (int k = 0; k < 16; ++k) {
    apply_variant(d, name, k);
    const bool tipped = k % 4 == 3;
    // On the ramp's rise, its plateau, or off it.
    const double px = k < 6 ? 1.5 + 0.3 * k : k < 12 ? 5.0 : -4.0;
    StateVector x = d.rest_state(px, -1.0 + 0.2 * u(rng), 0.3 + 0.5 * u(rng), 0.3 * u(rng), 0.05 * u(rng),
                                 0.8 + 0.5 * u(rng), 0.05 * u(rng));
    // Dig the wheels in a little, or lay the truck on its side with the body in the floor.
    x[StateIndex::kQ + kZ] += tipped ? -0.2 : -0.01 * std::abs(u(rng));
    x[StateIndex::kQ + kAuc] = tipped ? 1.35 + 0.1 * u(rng) : 0.05 * u(rng);
    x[StateIndex::kQ + kAvc] = 0.05 * u(rng);
    for (int i = 0; i < kNumDynamic; ++i) x[StateIndex::kQdot + i] = (i >= kAvr1 ? 8.0 : 0.8) * u(rng);
    for (int dd = 0; dd < kNumDriven; ++dd) {
      x[StateIndex::kDriven + 3 * dd + 1] = 0.1 * u(rng);
      x[StateIndex::kDriven + 3 * dd + 2] = 0.5 * u(rng);
    }
    x[StateIndex::kTorque] = 800 * u(rng);
    x[StateIndex::kBrake] = k % 3 == 0 ? 0.0 : 600 * std::abs(u(rng));
    for (int i = 0; i < 2 * kNumWheels; ++i) x[StateIndex::kTyre + i] = 0.01 * u(rng);
    x[StateIndex::kBrakeStick] = u(rng);
    x[StateIndex::kBrakeStick + 1] = u(rng);
    DriverInputs in;
    in.drive_torque_N_m = 1500 * u(rng);
    in.brake_torque_N_m = k % 2 ? 500 * std::abs(u(rng)) : 0.0;
    in.steer_rad = 1.2 * u(rng);
    in.tilt_rate_rad_s = 0.1 * u(rng);
    in.lift_rate_m_s = 0.4 * u(rng);
    in.shift_rate_m_s = 0.1 * u(rng);
    in.parking_brake = k % 5 == 4;
    out.push_back({x, in});
  }
  return out;
}

std::string reference_path() { return FORKLIFT_MODEL_REFERENCE; }

struct Evaluated {
  StateVector dx;
  MassMatrix M;
  CoordVector Q;
  Outputs out;
  bool ok;
};

Evaluated evaluate(const TruckDynamics& d, const PinnedState& s) {
  Evaluated e;
  e.ok = d.derivative(s.x, s.u, e.dx, &e.out);
  d.mass_matrix_and_forces(s.x, e.M, e.Q);
  return e;
}

}  // namespace

TEST(ModelReference, DISABLED_Regenerate) {
  json file;
  file["about"] = "States of the truck model with its derivative, M, Q, driven forces and applied power, "
                  "written by model_reference_test (see there); the model must reproduce them within 1e-12.";
  for (const char* name : kCases) {
    TruckDynamics d = dynamics_of(name);
    json samples = json::array();
    int k = 0;
    for (const PinnedState& s : states_of(name)) {
      apply_variant(d, name, k++);
      const Evaluated e = evaluate(d, s);
      ASSERT_TRUE(e.ok) << name << " sample " << k - 1;
      json j;
      j["x"] = vec(s.x);
      j["u"] = inputs_to(s.u);
      j["dx"] = vec(e.dx);
      j["M"] = vec(e.M.reshaped());
      j["Q"] = vec(e.Q);
      j["driven_force"] = vec(e.out.driven_force);
      j["applied_power_W"] = e.out.applied_power_W;
      j["body_points_on_ground"] = e.out.body_points_on_ground;
      samples.push_back(j);
    }
    file["cases"][name] = samples;
  }
  std::ofstream f(reference_path());
  ASSERT_TRUE(f) << reference_path();
  f << file.dump(1) << '\n';
}

TEST(ModelReference, ModelReproducesTheStoredStates) {
  std::ifstream f(reference_path());
  ASSERT_TRUE(f) << "missing " << reference_path();
  const json file = json::parse(f);
  int tipped = 0, total = 0;
  double worst_m = 0, worst_q = 0, worst_a = 0, worst_dx = 0;  // the largest error/scale of each, printed
  for (const char* name : kCases) {
    SCOPED_TRACE(name);
    const json& samples = file.at("cases").at(name);
    ASSERT_GE(samples.size(), 8u);
    TruckDynamics d = dynamics_of(name);
    // Per-component scale of dx outside q'' over the case, floored by its group's largest.
    StateVector scale = StateVector::Zero();
    for (const json& j : samples)
      for (int i = 0; i < StateIndex::kSize; ++i) scale[i] = std::max(scale[i], std::abs(j["dx"][i].get<double>()));
    auto floor_group = [&](int from, int n) {
      const double m = scale.segment(from, n).maxCoeff();
      for (int i = from; i < from + n; ++i) scale[i] = std::max(scale[i], 1e-6 * m);
    };
    floor_group(StateIndex::kQ, kNumDynamic);
    floor_group(StateIndex::kDriven, 3 * kNumDriven);
    floor_group(StateIndex::kTorque, 2);
    floor_group(StateIndex::kTyre, 2 * kNumWheels + 2);

    int k = 0;
    for (const json& j : samples) {
      SCOPED_TRACE("sample " + std::to_string(k));
      apply_variant(d, name, k++);
      PinnedState s;
      for (int i = 0; i < StateIndex::kSize; ++i) s.x[i] = j["x"][i];
      s.u = inputs_from(j["u"]);
      const Evaluated e = evaluate(d, s);
      ASSERT_TRUE(e.ok);
      MassMatrix M;
      CoordVector Q;
      StateVector dx;
      for (int i = 0; i < kNumCoords * kNumCoords; ++i) M.reshaped()[i] = j["M"][i];
      for (int i = 0; i < kNumCoords; ++i) Q[i] = j["Q"][i];
      for (int i = 0; i < StateIndex::kSize; ++i) dx[i] = j["dx"][i];
      const CoordVector sd = M.diagonal().cwiseSqrt();

      double m_err = 0;
      for (int a = 0; a < kNumCoords; ++a)
        for (int b = 0; b < kNumCoords; ++b) m_err = std::max(m_err, std::abs(e.M(a, b) - M(a, b)) / (sd[a] * sd[b]));
      EXPECT_LE(m_err, 1e-12);
      worst_m = std::max(worst_m, m_err);

      const double q_scale = Q.cwiseQuotient(sd).cwiseAbs().maxCoeff();
      EXPECT_LE((e.Q - Q).cwiseQuotient(sd).cwiseAbs().maxCoeff(), 1e-12 * q_scale);
      worst_q = std::max(worst_q, (e.Q - Q).cwiseQuotient(sd).cwiseAbs().maxCoeff() / q_scale);

      const auto sdd = sd.head<kNumDynamic>();
      const auto qdd = dx.segment<kNumDynamic>(StateIndex::kQdot);
      // At rest q'' is a small difference of balanced forces: its scale is theirs (in these
      // units a force and the acceleration it gives are alike).
      const double a_scale = std::max(qdd.cwiseProduct(sdd).cwiseAbs().maxCoeff(), q_scale);
      EXPECT_LE((e.dx.segment<kNumDynamic>(StateIndex::kQdot) - qdd).cwiseProduct(sdd).cwiseAbs().maxCoeff(),
                1e-12 * a_scale);
      worst_a = std::max(worst_a, (e.dx.segment<kNumDynamic>(StateIndex::kQdot) - qdd).cwiseProduct(sdd).cwiseAbs().maxCoeff() / a_scale);
      for (int i = 0; i < StateIndex::kSize; ++i) {
        if (i >= StateIndex::kQdot && i < StateIndex::kQdot + kNumDynamic) continue;
        EXPECT_LE(std::abs(e.dx[i] - dx[i]), 1e-12 * scale[i]) << "dx[" << i << "]";
        worst_dx = std::max(worst_dx, std::abs(e.dx[i] - dx[i]) / scale[i]);
      }

      Eigen::Vector4d lambda;
      for (int i = 0; i < kNumDriven; ++i) lambda[i] = j["driven_force"][i];
      EXPECT_LE((e.out.driven_force - lambda).cwiseAbs().maxCoeff(), 1e-12 * lambda.cwiseAbs().maxCoeff());
      const double power = j["applied_power_W"];
      EXPECT_NEAR(e.out.applied_power_W, power, 1e-12 * std::max(1.0, std::abs(power)));
      EXPECT_EQ(e.out.body_points_on_ground, j["body_points_on_ground"].get<int>());
      tipped += j["body_points_on_ground"].get<int>() > 0;
      ++total;
    }
  }
  std::printf("largest differences from the reference, in the scales above: M %.2g, Q %.2g, q'' %.2g, other dx %.2g\n",
              worst_m, worst_q, worst_a, worst_dx);
  // The file really covers what it claims: both manoeuvres on both trucks and tipped states.
  EXPECT_GE(total, 50);
  EXPECT_GE(tipped, 3);
}
