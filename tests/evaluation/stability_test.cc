// The stability triangle's margin against hand-computed cases, and the capacity plate's rule.
#include "evaluation/harness.h"
#include "forklift/dynamics/stability.h"

namespace {

using namespace evt;

// Distance from p to the line through a and b (plane x, y), computed independently.
double line_distance(const Vector2d& p, const Vector2d& a, const Vector2d& b) {
  const Vector2d d = b - a;
  return std::abs(d.x() * (p - a).y() - d.y() * (p - a).x()) / d.norm();
}

// A 3-wheel truck's triangle: front wheels 0.9 m apart, rear wheel 1.25 m behind.
const Vector3d kFl(0, 0.45, 0), kFr(0, -0.45, 0), kRear(-1.25, 0, 0);
const Vector3d kG(0, 0, -kGravity_m_s2);

TEST(StabilityMargin, AtRestTheNearestEdgeOfTheTriangle) {
  const Vector3d cog(-0.6, 0, 0.7);
  const Stability s = stability_margin(cog, kG, kFl, kFr, kRear);
  const double side = line_distance(Vector2d(-0.6, 0), Vector2d(0, 0.45), Vector2d(-1.25, 0));
  EXPECT_NEAR(side, 0.22017, 1e-5);
  EXPECT_NEAR(s.margin_m, side, 1e-12);
  EXPECT_EQ(s.edge, 1);  // left and right tie; the first found
  EXPECT_NEAR(s.cog_projection_m.x(), -0.6, 1e-12);
  // Moved forward until the front axle is nearest: 0.15 m from it.
  EXPECT_NEAR(stability_margin(Vector3d(-0.15, 0, 0.7), kG, kFl, kFr, kRear).margin_m, 0.15, 1e-12);
  EXPECT_EQ(stability_margin(Vector3d(-0.15, 0, 0.7), kG, kFl, kFr, kRear).edge, 0);
  // Beyond the front axle: negative.
  EXPECT_NEAR(stability_margin(Vector3d(0.1, 0, 0.7), kG, kFl, kFr, kRear).margin_m, -0.1, 1e-12);
}

TEST(StabilityMargin, BrakingAndCorneringMoveTheProjectionAlongTheApparentGravity) {
  const Vector3d cog(-0.3, 0, 0.8);
  // Braking at 2 m/s^2 going +x: apparent gravity g - a with a = (-2, 0, 0); the projection moves
  // forward by h a / g.
  const Stability brake = stability_margin(cog, kG - Vector3d(-2, 0, 0), kFl, kFr, kRear);
  EXPECT_NEAR(brake.cog_projection_m.x(), -0.3 + 0.8 * 2 / kGravity_m_s2, 1e-12);
  EXPECT_NEAR(brake.margin_m, 0.3 - 0.8 * 2 / kGravity_m_s2, 1e-12);
  EXPECT_EQ(brake.edge, 0);
  // Turning left at 1.5 m/s^2 (acceleration towards +y): the projection moves right.
  const Stability turn = stability_margin(cog, kG - Vector3d(0, 1.5, 0), kFl, kFr, kRear);
  const Vector2d p(-0.3, -0.8 * 1.5 / kGravity_m_s2);
  EXPECT_NEAR(turn.cog_projection_m.y(), p.y(), 1e-12);
  EXPECT_NEAR(turn.margin_m, line_distance(p, Vector2d(0, -0.45), Vector2d(-1.25, 0)), 1e-12);
  EXPECT_EQ(turn.edge, 2);
}

TEST(StabilityMargin, DoesNotDependOnHowTheWholeIsPlaced) {
  const Vector3d cog(-0.5, 0.1, 0.9), g = kG - Vector3d(0.7, -0.4, 0.1);
  const double m = stability_margin(cog, g, kFl, kFr, kRear).margin_m;
  const Eigen::Isometry3d T = Eigen::Translation3d(12, -3, 0.4) * Eigen::AngleAxisd(0.3, Vector3d(0.2, 1, 0.5).normalized());
  const Stability moved = stability_margin(T * cog, T.linear() * g, T * kFl, T * kFr, T * kRear);
  EXPECT_NEAR(moved.margin_m, m, 1e-12);
}

TEST(StabilityMargin, TheTruckAtRestIsItsOwnReference) {
  Session s(scene("zones.json"));
  s.tick();
  EXPECT_NEAR(s.stability().fraction, 1.0, 0.01);
  // The lateral edge, as above, for the truck's own CoG at rest.
  const StaticReport r = static_report(s.truck, std::nullopt, 0);
  EXPECT_NEAR(s.stability().margin_m,
              line_distance(r.cog_m.head<2>(), r.wheel_contact_m[forklift::kFrontRight], r.wheel_contact_m[forklift::kRear]), 0.01);
}

TEST(Capacity, ThePlateIsDeratedBeyondTheRatedLoadCentre) {
  TruckParams t;
  t.rated_capacity_kg = 1600;
  t.rated_load_centre_m = 0.5;
  EXPECT_DOUBLE_EQ(derated_capacity_kg(t, 0.5), 1600);
  EXPECT_DOUBLE_EQ(derated_capacity_kg(t, 0.3), 1600);  // never more than rated
  EXPECT_DOUBLE_EQ(derated_capacity_kg(t, 0.6), 1600 * 0.5 / 0.6);
  EXPECT_DOUBLE_EQ(derated_capacity_kg(t, 1.0), 800);
}

}  // namespace
