// The truck's contacts with the scene: which pairs, where, how deep, how fast.
#include <gtest/gtest.h>

#include <set>

#include "collision/fixture.h"

namespace {

using namespace fx;

const Contact* first_with(const std::vector<Contact>& cs, const std::string& part, const std::string& object) {
  for (const Contact& c : cs)
    if (c.truck_part == part && c.object_id == object) return &c;
  return nullptr;
}

// Drives between two racks: not one contact, although the truck passes right between them.
TEST(Collision, ClearAisleHasNoContacts) {
  const Scene scene = scene_of({rack("R1", pose(4, 2.2)), rack("R2", pose(4, -2.2)),
                                wall("W", box(12, -4, 0, 12.2, 4, 3))});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.1));
  run.run(5.0, [] { DriverInputs u; u.drive_torque_N_m = 420; return u; });
  // By the end the truck is between the racks (their span: x 2.65 to 5.35): front axle and
  // mast well inside, the forks near the far end.
  EXPECT_GT(run.poses().chassis.translation().x(), 3.5);
  EXPECT_TRUE(run.contacts.empty()) << run.contacts.size() << " contacts, first: " << run.contacts[0].second.truck_part
                                    << " with " << run.contacts[0].second.object_id;
}

// Drives into a rack across the aisle: contacts with that rack only, the first one at its
// near beam's face, the carriage's backrest striking it, normal pointing back at the truck.
TEST(Collision, DrivingIntoARackTouchesThatRackOnly) {
  // R1's length along world y; its near beams' face at x = 4 - 0.55 = 3.45.
  const Scene scene = scene_of({rack("R1", pose(4, 0, 0, 90)), rack("R2", pose(4, 4, 0, 90)),
                                wall("W", box(12, -4, 0, 12.2, 4, 3))});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.1));
  auto torque = [] { DriverInputs u; u.drive_torque_N_m = 300; return u; };
  ASSERT_TRUE(run.run(8.0, torque, [&] { return !run.contacts.empty(); }));
  const double v_at_contact = run.v();
  const double heel_at_contact = run.poses().carriage.translation().x();
  run.run(0.3, torque);

  std::set<std::string> objects;
  for (const auto& [t, c] : run.contacts) objects.insert(c.object_id);
  EXPECT_EQ(objects, std::set<std::string>{"R1"});

  const Contact& first = run.contacts.front().second;
  EXPECT_EQ(first.truck_part, "carriage");  // the backrest meets the level-1 beam; the forks pass below it
  EXPECT_EQ(first.object_kind, ObjectKind::kRack);
  EXPECT_NEAR(first.point_m.x(), 3.45, 0.01);
  EXPECT_GT(first.point_m.z(), 0.8);  // on the beam (0.8 to 0.9 m)
  EXPECT_LT(first.point_m.z(), 0.9);
  EXPECT_LT(first.normal.x(), -0.99);
  EXPECT_GT(first.depth_m, 0);
  EXPECT_LT(first.depth_m, v_at_contact * Driven::kTick + 0.001);  // at most one tick's travel in
  EXPECT_NEAR(first.relative_speed_m_s, v_at_contact, 0.1 * v_at_contact);
  // The rack pushes back: with the drive still on, the truck is held within a few centimetres
  // of the beam's face (it would have driven on 0.2 m in 0.3 s), rebounding and pressing again.
  EXPECT_LT(run.poses().carriage.translation().x(), heel_at_contact + 0.06);
  EXPECT_LT(std::abs(run.v()), 0.5 * v_at_contact);
  EXPECT_GT(run.contacts.size(), 1u);
}

// A truck held at 1 m/s runs its forks into a wall: the contact's relative speed is the
// truck's speed and its depth at most one tick's travel.
TEST(Collision, WallAtOneMetrePerSecond) {
  const Scene scene = scene_of({wall("W", box(4.0, -3, 0, 4.2, 3, 3))});
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.1));
  ASSERT_TRUE(run.run(10.0, [&] { return hold_speed(1.0, run.v()); }, [&] { return !run.contacts.empty(); }));
  EXPECT_NEAR(run.v(), 1.0, 0.03);
  for (const auto& [t, c] : run.contacts) {
    EXPECT_EQ(c.object_id, "W");
    EXPECT_TRUE(c.truck_part == "fork_left" || c.truck_part == "fork_right") << c.truck_part;
    EXPECT_NEAR(c.relative_speed_m_s, 1.0, 0.05);
    EXPECT_NEAR(c.relative_speed_m_s, run.v(), 0.02 * run.v());
    EXPECT_GT(c.depth_m, 0);
    EXPECT_LE(c.depth_m, 0.0015);
    EXPECT_LT(c.normal.x(), -0.99);
    EXPECT_NEAR(c.point_m.x(), 4.0, 0.002);
  }
  // One contact per (part, object) pair per tick: both forks, once each.
  EXPECT_LE(run.contacts.size(), 2u);
}

// A person standing 4 m ahead, then one whose state has him walking towards the truck at 1 m/s:
// struck by the forks, each a contact naming him, at the speed they close at; neither pushes back.
TEST(Collision, PeopleAreStruckAndGiveWay) {
  for (const double walking : {0.0, 1.0}) {
    SCOPED_TRACE(walking);
    Scene scene = scene_of({});
    PedestrianSpec p;
    p.id = "W1";
    p.path = {Eigen::Vector2d(4.15, 0), Eigen::Vector2d(-10, 0)};
    p.speed_m_s = 1.0;
    p.looks = false;
    scene.pedestrians.push_back(p);
    TruckDynamics d(truck());
    Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.1));
    run.people = initial_pedestrians(scene.pedestrians);  // at x = 4.15, his chest at 4.0, facing -x
    run.people[0].speed_m_s = walking;
    ASSERT_TRUE(run.run(10.0, [&] { return hold_speed(1.0, run.v()); }, [&] { return !run.contacts.empty(); }));
    const Contact& c = run.contacts.front().second;
    EXPECT_EQ(c.object_id, "W1");
    EXPECT_EQ(c.object_kind, ObjectKind::kPedestrian);
    EXPECT_EQ(c.pedestrian, 0);
    EXPECT_TRUE(c.truck_part == "fork_left" || c.truck_part == "fork_right") << c.truck_part;
    EXPECT_NEAR(c.point_m.x(), 4.0, 0.002);
    EXPECT_NEAR(c.relative_speed_m_s, run.v() + walking, 0.05);
    // Driven on into him for 0.2 s: nothing holds the truck back.
    const double v = run.v();
    run.run(0.2, [&] { return hold_speed(1.0, run.v()); });
    EXPECT_NEAR(run.v(), v, 0.05);
  }
  // With no states given, nobody stands there.
  Scene scene = scene_of({});
  PedestrianSpec p;
  p.id = "W1";
  p.path = {Eigen::Vector2d(4.15, 0), Eigen::Vector2d(-10, 0)};
  p.speed_m_s = 1.0;
  scene.pedestrians.push_back(p);
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.1));
  EXPECT_FALSE(run.run(4.0, [&] { return hold_speed(1.0, run.v()); }, [&] { return !run.contacts.empty(); }));
}

// Backing away from a wall the forks are in: once the truck moves back, no speed into it.
TEST(Collision, RelativeSpeedIsZeroMovingAway) {
  const Scene scene = scene_of({wall("W", box(1.37, -3, 0, 1.6, 3, 3))});  // the fork tips (x 1.4) 3 cm in
  TruckDynamics d(truck());
  Driven run(scene, truck_shape(), settled(d, 0, 0, 0, 0.1));
  int checked = 0;
  for (int tick = 0; tick < 500; ++tick) {
    const size_t before = run.contacts.size();
    run.run(Driven::kTick, [&] { return hold_speed(-0.5, run.v()); });
    if (run.v() > -0.05) continue;  // starting off, the pitching truck still nods its forks in
    for (size_t i = before; i < run.contacts.size(); ++i, ++checked) {
      EXPECT_EQ(run.contacts[i].second.relative_speed_m_s, 0.0);
      EXPECT_LT(run.contacts[i].second.normal.x(), -0.99) << run.contacts[i].second.normal.transpose() << " d " << run.contacts[i].second.depth_m << " p " << run.contacts[i].second.point_m.transpose() << " tip " << run.poses().carriage.translation().x() + 1.0;
    }
  }
  EXPECT_GT(checked, 10);
  EXPECT_LT(run.poses().carriage.translation().x() + 1.0, 1.37);  // out of the wall by the end
}

class Static : public ::testing::Test {
 protected:
  TruckDynamics d{truck()};
  // Forks in the middle of a EUR pallet's pocket height (fork top 0.092 m).
  StateVector x0 = settled(d, 0, 0, 0, 0.092);
  CoordVector q = coordinates(x0);
  double tip_x = body_poses(truck(), q).carriage.translation().x() + 1.0;
};

// Forks inside the pockets are no contact; the same forks 16 cm to the side strike the blocks.
TEST_F(Static, ForksInPocketsAreNoContactForksInBlocksAre) {
  const double inserted = 0.9;
  const double cx = tip_x - inserted + 0.6;
  Warehouse in(scene_of({pallet("P1", pose(cx, 0), eur_pallet())}), truck_shape(), truck());
  EXPECT_TRUE(in.contacts_at(q).empty());

  Warehouse beside(scene_of({pallet("P2", pose(cx, 0.16), eur_pallet())}), truck_shape(), truck());
  const std::vector<Contact> cs = beside.contacts_at(q);
  const Contact* left = first_with(cs, "fork_left", "P2");
  const Contact* right = first_with(cs, "fork_right", "P2");
  ASSERT_TRUE(left && right);
  for (const Contact* c : {left, right}) {
    EXPECT_EQ(c->object_kind, ObjectKind::kPallet);
    EXPECT_GT(c->depth_m, 0);
    EXPECT_LE(c->depth_m, 0.1);  // the fork is 0.1 m wide
    EXPECT_EQ(c->relative_speed_m_s, 0.0);  // contacts_at knows no velocity
  }
  EXPECT_EQ(cs.size(), 2u);  // one per pair, however many block boxes each fork meets
}

// The same holds for a pallet without a mesh: its boxes come from the spec.
TEST_F(Static, PalletBoxesFromTheSpec) {
  const double cx = tip_x - 0.9 + 0.6;
  Warehouse in(scene_of({pallet("P1", pose(cx, 0), eur_pallet(), false)}), truck_shape(), truck());
  EXPECT_TRUE(in.contacts_at(q).empty());
  Warehouse beside(scene_of({pallet("P2", pose(cx, 0.16), eur_pallet(), false)}), truck_shape(), truck());
  EXPECT_EQ(beside.contacts_at(q).size(), 2u);
  // Forks too high: in the deck (0.122 to 0.144 m) at the entry face.
  CoordVector high = q;
  high[kS] += 0.06;
  const std::vector<Contact> cs = in.contacts_at(high);
  EXPECT_TRUE(first_with(cs, "fork_left", "P1") && first_with(cs, "fork_right", "P1"));
}

// The floor is the tyre model's: forks pushed into a floor slab are no contact.
TEST_F(Static, FloorIsNoContact) {
  SceneObject slab = wall("floor", box(-10, -10, -0.2, 10, 10, 0.0));
  slab.kind = ObjectKind::kObstacle;
  Warehouse w(scene_of({slab}), truck_shape(), truck());
  CoordVector low = q;
  low[kZ] -= 0.15;  // forks and chassis floor below z = 0
  EXPECT_LT(body_poses(truck(), low).carriage.translation().z() - 0.04, 0);
  EXPECT_TRUE(w.contacts_at(low).empty());
}

// A truck shape without meshes still has forks, from its dimensions.
TEST(Collision, NoMeshesMeansForksOnly) {
  TruckShape bare;  // no meshes: forks from the dimensions alone
  TruckDynamics d(truck());
  const CoordVector q = coordinates(settled(d, 0, 0, 0, 0.1));
  Warehouse w(scene_of({wall("W", box(1.3, -3, 0, 1.5, 3, 0.3))}), bare, truck());
  const std::vector<Contact> cs = w.contacts_at(q);
  ASSERT_EQ(cs.size(), 2u);
  EXPECT_TRUE(first_with(cs, "fork_left", "W"));
  EXPECT_TRUE(first_with(cs, "fork_right", "W"));
}

// The shipped warehouse with the shipped truck: aisle A (y 24.4 to 27.9, racks R1-R4 north of
// it, R5-R8 south) driven end to end along its middle is clear.
TEST(ShippedWarehouse, AisleAIsClear) {
  const Scene& scene = shipped_warehouse();
  TruckDynamics d(truck());
  Driven run(scene, shipped_shape(), settled(d, 9.5, 26.15, 0, 0.1));
  run.run(7.0, [] { DriverInputs u; u.drive_torque_N_m = 420; return u; });
  EXPECT_GT(run.poses().chassis.translation().x(), 17.0);  // the whole truck among the racks
  EXPECT_TRUE(run.contacts.empty()) << run.contacts[0].second.truck_part << " with " << run.contacts[0].second.object_id;
}

// Turned towards R4 across aisle A and driven into it: contacts with R4 and nothing else; the
// carriage's backrest meets its level-1 beam (top 0.9 m) at the rack's face, y = 27.9.
TEST(ShippedWarehouse, DrivingIntoRackR4TouchesR4Only) {
  const Scene& scene = shipped_warehouse();
  TruckDynamics d(truck());
  Driven run(scene, shipped_shape(), settled(d, 21.0, 26.1, M_PI / 2, 0.1));
  auto torque = [] { DriverInputs u; u.drive_torque_N_m = 300; return u; };
  ASSERT_TRUE(run.run(8.0, torque, [&] { return !run.contacts.empty(); }));
  const double v_at_contact = run.v();
  run.run(0.3, torque);
  std::set<std::string> objects;
  for (const auto& [t, c] : run.contacts) objects.insert(c.object_id);
  EXPECT_EQ(objects, std::set<std::string>{"R4"});
  const Contact& first = run.contacts.front().second;
  EXPECT_EQ(first.truck_part, "carriage");
  EXPECT_NEAR(first.point_m.y(), 27.9, 0.01);
  EXPECT_GT(first.point_m.z(), 0.8);
  EXPECT_LT(first.point_m.z(), 0.9);
  EXPECT_LT(first.normal.y(), -0.99);
  EXPECT_NEAR(first.relative_speed_m_s, v_at_contact, 0.1 * v_at_contact);
}

TEST(Collision, EventNames) {
  EXPECT_STREQ(handling_event_name(HandlingEvent::Kind::kPickedUp), "picked_up");
  EXPECT_STREQ(handling_event_name(HandlingEvent::Kind::kSetDown), "set_down");
  EXPECT_STREQ(handling_event_name(HandlingEvent::Kind::kSliding), "sliding");
  EXPECT_STREQ(handling_event_name(HandlingEvent::Kind::kDropped), "dropped");
}

}  // namespace
