// The unladen truck overturning sideways in a sharp turn at top speed, against the stability
// triangle: the classic three-wheel counterbalance accident.
//
// Closed form (a rigid truck in a steady turn): the truck tips about the edge from the outer front
// wheel's contact to the rear wheel's, when the horizontal acceleration of its centre of gravity,
// taken along that edge's outward normal n, reaches a_tip = g d / h (d the CoG's horizontal
// distance to the edge, h its height). Going forward at v with the rear wheel steered to phi, the
// truck turns about the point on the front axle's line L / tan(phi) from its middle (L the
// wheelbase), at the yaw rate v tan(phi) / L, and the CoG's acceleration is w^2 towards that point.
// Both on the training truck's tyres (with a grip peak and a sliding drop) and on the brush
// without a peak it had before (data/tyres/linde_e16c_brush.json).
#include <gtest/gtest.h>

#include <cmath>
#include <optional>

#include "forklift/dynamics/simulation.h"
#include "forklift/dynamics/stability.h"
#include "forklift/units/units.h"
#include "test_truck.h"

using namespace forklift;

namespace {

constexpr double kTopSpeed_m_s = 16 / 3.6;

// The stability triangle of the unladen truck turning right (+ steer): the outer edge is the
// front-left contact to the rear contact.
struct Triangle {
  Eigen::Vector2d cog, front_left, front_middle, n;  // n: the edge's outward normal, horizontal
  double d = 0, h = 0;
  double a_tip() const { return kGravity_m_s2 * d / h; }
};

Triangle unladen_triangle(const TruckParams& t) {
  const StaticReport s = static_report(t, std::nullopt, 0);
  Triangle tr;
  tr.cog = s.cog_m.head<2>();
  tr.h = s.cog_m.z();
  tr.front_left = s.wheel_contact_m[kFrontLeft];
  tr.front_middle = 0.5 * (s.wheel_contact_m[kFrontLeft] + s.wheel_contact_m[kFrontRight]);
  const Eigen::Vector2d e = (s.wheel_contact_m[kRear] - tr.front_left).normalized();
  tr.n = Eigen::Vector2d(-e.y(), e.x());
  if (tr.n.dot(tr.front_left - tr.cog) < 0) tr.n = -tr.n;
  tr.d = tr.n.dot(tr.front_left - tr.cog);
  return tr;
}

// The CoG's outward acceleration along n in a steady kinematic turn at `v` with the rear steered `phi`.
double kinematic_outward_acceleration(const Triangle& tr, double wheelbase, double v, double phi) {
  const double radius = wheelbase / std::tan(phi);  // to the right of the front axle's middle
  const Eigen::Vector2d centre = tr.front_middle - Eigen::Vector2d(0, radius);
  const double w = v / radius;
  return w * w * (tr.cog - centre).dot(tr.n);
}

// The steer angle at which that acceleration reaches a_tip (it grows with the angle).
double predicted_tip_steer(const Triangle& tr, double wheelbase, double v) {
  double lo = 1 * kDeg, hi = 60 * kDeg;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (kinematic_outward_acceleration(tr, wheelbase, v, mid) < tr.a_tip() ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

struct TurnResult {
  double final_roll_deg = 0, largest_roll_deg = 0;
  double outward_acceleration_at_lift = NAN;  // along n, when the inner (right) front wheel lifts
  double rear_friction_use = 0;               // the rear tyre's largest share of its grip
  bool at_rest_on_body = false;
};

// Full throttle from rest for 10 s, to the governor's top speed.
StateVector at_top_speed(const TruckDynamics& dyn) {
  StateVector x = dyn.rest_state(0, 0, 0);
  EXPECT_TRUE(dyn.settle_static(x));
  Simulation sim(dyn, x, IntegratorOptions{});
  DriverInputs u;
  u.drive_torque_N_m = dyn.truck().drive.drive_torque_max_N_m;
  sim.set_inputs(u);
  sim.advance_to(10);
  return sim.state();
}

// From `start`, a steer step to `phi` with the throttle held (the governor keeps the speed), for 6 s.
TurnResult steer_step(const TruckDynamics& dyn, const StateVector& start, const Triangle& tr, double phi) {
  Simulation sim(dyn, start, IntegratorOptions{});
  DriverInputs u;
  u.drive_torque_N_m = dyn.truck().drive.drive_torque_max_N_m;
  u.steer_rad = phi;
  sim.set_inputs(u);
  TurnResult r;
  Outputs o;
  for (int k = 1; k <= 600; ++k) {
    sim.advance_to(sim.time() + 0.01);
    o = sim.outputs();
    r.largest_roll_deg = std::max(r.largest_roll_deg, std::abs(o.q[kAuc]) / kDeg);
    r.rear_friction_use = std::max(r.rear_friction_use, o.wheels[kRear].friction_use);
    if (std::isnan(r.outward_acceleration_at_lift) && o.wheels[kFrontRight].fz_N <= 0) {
      const double yaw = o.q[kAwc];
      const Eigen::Vector2d a(o.qddot[kX], o.qddot[kY]);  // world; n is in the truck's axes
      const Eigen::Vector2d n(std::cos(yaw) * tr.n.x() - std::sin(yaw) * tr.n.y(),
                              std::sin(yaw) * tr.n.x() + std::cos(yaw) * tr.n.y());
      // The chassis CoG's acceleration; outward is away from the turn, the inertial side.
      r.outward_acceleration_at_lift = -a.dot(n);
    }
  }
  r.final_roll_deg = std::abs(o.q[kAuc]) / kDeg;
  r.at_rest_on_body = Eigen::Vector3d(o.qdot[kX], o.qdot[kY], o.qdot[kZ]).norm() < 0.05 && o.body_points_on_ground > 1;
  return r;
}

void tips_at_the_stability_triangles_steer_angle(const TruckParams& t) {
  const Triangle tr = unladen_triangle(t);
  ASSERT_GT(tr.d, 0);
  const double predicted = predicted_tip_steer(tr, t.wheelbase_m(), kTopSpeed_m_s);
  const TruckDynamics dyn(t);
  const StateVector start = at_top_speed(dyn);
  EXPECT_NEAR(forward_speed(start), kTopSpeed_m_s, 0.5 / 3.6) << "the turn starts at 16 km/h";

  // At the predicted angle (and a little above, for the tyres' slip), it ends on its side.
  const TurnResult over = steer_step(dyn, start, tr, 1.1 * predicted);
  EXPECT_GT(over.final_roll_deg, 60) << "steer " << 1.1 * predicted / kDeg << " deg";
  EXPECT_TRUE(over.at_rest_on_body);
  // It lifts its inner front wheel at the stability triangle's lateral acceleration.
  EXPECT_NEAR(over.outward_acceleration_at_lift / tr.a_tip(), 1.0, 0.15)
      << over.outward_acceleration_at_lift << " m/s^2 against g d / h = " << tr.a_tip();

  // Below it, it stays on its wheels.
  const TurnResult upright = steer_step(dyn, start, tr, 0.85 * predicted);
  EXPECT_LT(upright.largest_roll_deg, t.tipped_over_rad / kDeg) << "steer " << 0.85 * predicted / kDeg << " deg";
  EXPECT_LT(upright.final_roll_deg, 5);

  // The angle where it starts to go over, found by bisection, against the closed form.
  double lo = 0.85 * predicted, hi = 1.1 * predicted;
  for (int i = 0; i < 4; ++i) {
    const double mid = 0.5 * (lo + hi);
    (steer_step(dyn, start, tr, mid).final_roll_deg > 60 ? hi : lo) = mid;
  }
  const double critical = 0.5 * (lo + hi);
  testing::Test::RecordProperty("tip_steer_deg", std::to_string(critical / kDeg) + " (closed form " +
                                                     std::to_string(predicted / kDeg) + ")");
  testing::Test::RecordProperty("lift_acceleration_m_s2", std::to_string(over.outward_acceleration_at_lift) +
                                                              " (g d / h " + std::to_string(tr.a_tip()) + ")");
  EXPECT_NEAR(critical / predicted, 1.0, 0.15)
      << "tips from " << critical / kDeg << " deg; the stability triangle says " << predicted / kDeg << " deg";
}

// At full lock the rear wheel stands almost across the truck's path: its force mostly brakes the
// truck, and its tyre saturates within the first few tenths of a second, before the yaw rate (and
// with it the lateral acceleration) has built up: the truck slides round and stops upright.
void skids_at_full_lock(const TruckParams& t) {
  const TruckDynamics dyn(t);
  const TurnResult r = steer_step(dyn, at_top_speed(dyn), unladen_triangle(t), t.steer.max_rad);
  EXPECT_GE(r.rear_friction_use, 0.9);  // saturated (the brush without a peak nears its grip only asymptotically)
  EXPECT_LT(r.final_roll_deg, 5);
  EXPECT_LT(r.largest_roll_deg, t.tipped_over_rad / kDeg);
}

// Where skidding takes over from tipping, against the grip of the rear tyre. In a steady turn the
// rear tyre carries a_f / L of the weight (a_f: the CoG behind the front axle, L the wheelbase)
// and, for the yaw moments about the CoG to balance, the same share a_f / L of the lateral force
// m a_y; only cos(phi) of its own sideways force is across the truck. So a_y <= mu g cos(phi),
// whatever a_f: a steady turn reaches the tipping acceleration g d / h only while
// mu cos(phi) > d / h. At that angle, with the tyre's sliding grip (the least it has), the truck
// still tips; beyond it only the step's transient (the yaw the front tyres start before the rear
// one saturates) can tip it, so the angle from which it skids lies between that and full lock.
void tips_while_the_rear_tyre_can_hold_the_turn_and_skids_beyond(const TruckParams& t) {
  const Triangle tr = unladen_triangle(t);
  const double steady_limit = std::acos(tr.d / (tr.h * t.contact.mu_sliding));
  const double peak_limit = std::acos(tr.d / (tr.h * t.contact.mu_static));
  ASSERT_LT(steady_limit, t.steer.max_rad);
  const TruckDynamics dyn(t);
  const StateVector start = at_top_speed(dyn);
  EXPECT_GT(steer_step(dyn, start, tr, steady_limit).final_roll_deg, 60)
      << "the rear tyre's sliding grip holds a turn at g d / h up to " << steady_limit / kDeg << " deg";
  // The angle from which it skids, by bisection between that and full lock.
  double lo = steady_limit, hi = t.steer.max_rad;
  for (int i = 0; i < 6; ++i) {
    const double mid = 0.5 * (lo + hi);
    (steer_step(dyn, start, tr, mid).final_roll_deg > 60 ? lo : hi) = mid;
  }
  const double skids_from = 0.5 * (lo + hi);
  const std::string tyre = t.contact.tyre == TyreModel::kGripPeak ? "grip_peak_" : "brush_";
  testing::Test::RecordProperty(tyre + "skids_from_deg", std::to_string(skids_from / kDeg) + " (steady rear-grip limit " +
                                                      std::to_string(steady_limit / kDeg) + " sliding, " +
                                                      std::to_string(peak_limit / kDeg) + " at the peak)");
  EXPECT_GT(skids_from, steady_limit);
  EXPECT_LT(skids_from, t.steer.max_rad - 2 * kDeg) << "it skids before the end stop";
}

}  // namespace

TEST(TipOver, UnladenSharpTurnAtTopSpeedTipsAtTheStabilityTrianglesSteerAngle) {
  tips_at_the_stability_triangles_steer_angle(shipped_truck());
}

TEST(TipOver, SoItDoesOnTheBrushTyreWithoutAPeak) {
  tips_at_the_stability_triangles_steer_angle(brush_truck());
}

TEST(TipOver, AtFullLockTheRearTyreSlidesAndTheTruckDoesNotTip) {
  skids_at_full_lock(shipped_truck());
  skids_at_full_lock(brush_truck());
}

TEST(TipOver, ItTipsWhileTheRearTyreCanHoldTheTurnAndSkidsBeyond) {
  tips_while_the_rear_tyre_can_hold_the_turn_and_skids_beyond(shipped_truck());
  tips_while_the_rear_tyre_can_hold_the_turn_and_skids_beyond(brush_truck());
}
