// The forks against the pallet ahead (pallet_approach): what the cab's lining-up hint says.
#include "fixture.h"

namespace {

using namespace fx;

struct Ahead : testing::Test {
  const PalletSpec spec = eur_pallet();
  const Scene scene = scene_of({pallet("P1", pose(3.0, 0), spec)});  // its near face at x = 2.4
  TruckDynamics d{truck()};
  Warehouse warehouse{scene, truck_shape(), truck()};
  // The truck at (0, y) heading yaw_deg, its fork top heel_z above the floor.
  std::optional<PalletApproach> at(double y, double yaw_deg, double heel_z, double x = 0) {
    const StateVector s = settled(d, x, y, yaw_deg * M_PI / 180, heel_z);
    return pallet_approach(scene, warehouse.initial_handling().pallets(), body_poses(truck(), coordinates(s)), truck_shape());
  }
};

TEST_F(Ahead, SquareAndAtPocketHeightIsLinedUp) {
  const auto a = at(0, 0, 0.09);  // fork middle 0.07 m up, the pockets' middle 0.072 m
  ASSERT_TRUE(a);
  EXPECT_EQ(a->pallet, "P1");
  const BodyPoses p = body_poses(truck(), coordinates(settled(d, 0, 0, 0, 0.09)));
  const double tips = (p.carriage * Vector3d(1.0, 0, 0)).x();
  EXPECT_NEAR(a->distance_m, 2.4 - tips, 0.01);
  EXPECT_LT(std::abs(a->height_m), a->height_tolerance_m);
  EXPECT_NEAR(a->lateral_m, 0, 0.005);
  EXPECT_NEAR(a->angle_rad, 0, 0.002);
  EXPECT_NEAR(a->height_tolerance_m, 0.03, 1e-9);   // (0.100 pocket - 0.040 fork) / 2
  EXPECT_NEAR(a->lateral_tolerance_m, 0.025, 1e-9);  // fork edge 0.230 against the pocket's 0.255
  EXPECT_FALSE(a->engaged);
}

TEST_F(Ahead, SaysHowMuchTooHighTooFarLeftAndTurned) {
  // 6 cm higher at the heel is about 6 cm higher at the pallet's face (the forks pitch a little
  // with the truck's stance, the same for both).
  const auto level = at(0, 0, 0.09), high = at(0, 0, 0.15);
  ASSERT_TRUE(level && high);
  EXPECT_NEAR(high->height_m - level->height_m, 0.06, 0.003);
  EXPECT_GT(high->height_m, high->height_tolerance_m);
  const auto left = at(0.06, 0, 0.09);
  ASSERT_TRUE(left);
  EXPECT_NEAR(left->lateral_m, 0.06, 0.005);
  const auto turned = at(0, 5, 0.09);
  ASSERT_TRUE(turned);
  EXPECT_NEAR(turned->angle_rad, 5 * M_PI / 180, 0.002);
  EXPECT_GT(turned->lateral_m, 0.0);  // turned left, the forks' line reaches the face left of centre
}

TEST_F(Ahead, ANamedPalletAloneIsLookedAt) {
  const StateVector s = settled(d, 0, 0, 0, 0.09);
  const BodyPoses poses = body_poses(truck(), coordinates(s));
  const auto named = pallet_approach(scene, warehouse.initial_handling().pallets(), poses, truck_shape(), 3.0, "P1");
  ASSERT_TRUE(named);
  EXPECT_EQ(named->pallet, "P1");
  EXPECT_FALSE(pallet_approach(scene, warehouse.initial_handling().pallets(), poses, truck_shape(), 3.0, "P2"))
      << "P1 is ahead, but the one asked about is another";
}

TEST_F(Ahead, NothingBehindTheForksOrOutOfRange) {
  EXPECT_FALSE(at(0, 180, 0.09));     // facing away
  EXPECT_FALSE(at(0, 0, 0.09, -4.0)); // 5 m short of it
  EXPECT_FALSE(at(1.5, 0, 0.09));     // beside the aisle it is in
}

}  // namespace
