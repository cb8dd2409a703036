// The warehouse's and the truck's meshes built from boxes (written as OBJ + MTL by the mesh
// module, assimp_files.cc).
#include "mesh_builder.h"

#include <cmath>
#include <memory>
#include <stdexcept>

#include "mesh_files.h"

namespace forklift::meshgen {
namespace {

using V = Eigen::Vector3f;

// The palette. Names become OBJ material names.
const Colour kRackBlue{"rack_blue", {0.12f, 0.25f, 0.55f}};
const Colour kRackOrange{"rack_orange", {0.90f, 0.40f, 0.08f}};
const Colour kGalvanised{"galvanised", {0.62f, 0.64f, 0.66f}};
const Colour kWood{"wood", {0.78f, 0.62f, 0.42f}};
const Colour kWoodDark{"wood_dark", {0.62f, 0.47f, 0.30f}};
const Colour kCardboard{"cardboard", {0.72f, 0.55f, 0.34f}};
const Colour kWall{"wall", {0.84f, 0.84f, 0.80f}};
const Colour kConcrete{"concrete", {0.58f, 0.58f, 0.56f}};
const Colour kSafetyYellow{"safety_yellow", {0.95f, 0.78f, 0.08f}};
const Colour kRubber{"rubber", {0.08f, 0.08f, 0.08f}};
const Colour kSteel{"steel", {0.50f, 0.52f, 0.55f}};
const Colour kDarkSteel{"dark_steel", {0.20f, 0.20f, 0.22f}};
const Colour kTrailerWhite{"trailer_white", {0.90f, 0.90f, 0.88f}};
const Colour kCabBlue{"cab_blue", {0.15f, 0.30f, 0.65f}};
const Colour kGlass{"glass", {0.25f, 0.35f, 0.42f}};
const Colour kConeOrange{"cone_orange", {1.00f, 0.42f, 0.05f}};
const Colour kWhite{"white", {0.95f, 0.95f, 0.95f}};
const Colour kHiVis{"hi_vis", {0.80f, 0.95f, 0.10f}};
const Colour kDenim{"denim", {0.18f, 0.24f, 0.42f}};
const Colour kSkin{"skin", {0.88f, 0.70f, 0.58f}};
const Colour kTruckRed{"truck_red", {0.72f, 0.08f, 0.08f}};
const Colour kSeat{"seat_black", {0.12f, 0.12f, 0.13f}};

// Appends a flat face with its own corners (so its normal stays sharp).
void add_face(Part& p, const std::vector<V>& corners, const V& normal) {
  std::vector<uint32_t> f;
  for (const V& c : corners) {
    f.push_back(static_cast<uint32_t>(p.positions.size()));
    p.positions.push_back(c);
    p.normals.push_back(normal);
  }
  p.faces.push_back(std::move(f));
}

// --- the meshes --------------------------------------------------------------------------

// One pallet-rack bay: 2.7 m long (x), 1.1 m deep (y); beams at three levels. The beams'
// tops are the levels a pallet stands on; scenario files repeat them as "levels_m".
constexpr float kRackHalfLength = 1.35f, kRackHalfDepth = 0.55f;
constexpr float kUpright = 0.08f;         // upright section, square
constexpr float kUprightHeight = 3.2f;    // above the top level's loads' bottom
constexpr float kBeamDepth = 0.05f, kBeamHeight = 0.10f;
constexpr float kBeamTops[] = {0.9f, 1.8f, 2.7f};

MeshSpec rack() {
  MeshSpec m{"rack.obj", {}};
  const float xo = kRackHalfLength, xi = kRackHalfLength - kUpright;
  const float yo = kRackHalfDepth, yi = kRackHalfDepth - kUpright;
  int n = 0;
  for (float sx : {-1.f, 1.f})
    for (float sy : {-1.f, 1.f}) {
      const V a(sx * xo, sy * yo, 0), b(sx * xi, sy * yi, kUprightHeight);
      m.parts.push_back(box("upright_" + std::to_string(n++), a.cwiseMin(b), a.cwiseMax(b), kRackBlue));
    }
  // Horizontal braces of each upright frame (between its front and back uprights).
  const float brace_z[] = {0.15f, 1.45f, 3.05f};
  for (int e = 0; e < 2; ++e) {
    const float sx = e == 0 ? -1.f : 1.f;
    const V a(sx * xo, -yi, 0), b(sx * xi, yi, 0);
    for (int k = 0; k < 3; ++k)
      m.parts.push_back(box("brace_" + std::to_string(e) + "_" + std::to_string(k),
                            V(std::min(a.x(), b.x()), -yi, brace_z[k]),
                            V(std::max(a.x(), b.x()), yi, brace_z[k] + 0.05f), kRackBlue));
  }
  for (int l = 0; l < 3; ++l) {
    const float top = kBeamTops[l];
    const std::string base = "beam_l" + std::to_string(l + 1) + "_";
    m.parts.push_back(box(base + "0", V(-xi, yo - kBeamDepth, top - kBeamHeight), V(xi, yo, top), kRackOrange));
    m.parts.push_back(box(base + "1", V(-xi, -yo, top - kBeamHeight), V(xi, -yo + kBeamDepth, top), kRackOrange));
  }
  return m;
}

// EUR pallet 1.2 x 0.8 x 0.144 m (EN 13698-1), forks entering along x: three bottom boards
// across (along y), three block rows along x whose gaps are the two pockets, one top deck.
MeshSpec pallet() {
  MeshSpec m{"pallet.obj", {}};
  const float hl = 0.6f, hw = 0.4f;
  const float board = 0.022f, block_top = 0.122f, deck_top = 0.144f;
  // Boards 0.145 m wide at the ends and the middle; block rows 0.145 m wide centred on y = 0
  // and +-0.3275, so the pockets span y in [0.0725, 0.255] and [-0.255, -0.0725].
  const char* where[] = {"back", "middle", "front"};
  const float board_x[3][2] = {{-0.6f, -0.455f}, {-0.0725f, 0.0725f}, {0.455f, 0.6f}};
  for (int i = 0; i < 3; ++i)
    m.parts.push_back(box(std::string("bottom_") + where[i], V(board_x[i][0], -hw, 0), V(board_x[i][1], hw, board),
                          kWoodDark));
  const char* rows[] = {"right", "centre", "left"};
  const float row_y[3][2] = {{-0.4f, -0.255f}, {-0.0725f, 0.0725f}, {0.255f, 0.4f}};
  for (int i = 0; i < 3; ++i)
    m.parts.push_back(box(std::string("blocks_") + rows[i], V(-hl, row_y[i][0], board), V(hl, row_y[i][1], block_top),
                          kWoodDark));
  m.parts.push_back(box("deck", V(-hl, -hw, block_top), V(hl, hw, deck_top), kWood));
  return m;
}

// Unit boxes, scaled per object (loads by PalletSpec::load_size_m, walls and obstacles by
// their "scale").
MeshSpec unit_box(const std::string& file, const std::string& part, const Colour& colour) {
  return MeshSpec{file, {box(part, V(-0.5f, -0.5f, 0), V(0.5f, 0.5f, 1), colour)}};
}

// A doorway 4 m wide and 4 m high in a 0.2 m wall 5 m high: two jambs and a lintel.
MeshSpec door() {
  MeshSpec m{"door.obj", {}};
  const float half_open = 2.0f, jamb = 0.3f, t = 0.1f, open_h = 4.0f, wall_h = 5.0f;
  m.parts.push_back(box("jamb_left", V(-half_open - jamb, -t, 0), V(-half_open, t, wall_h), kWall));
  m.parts.push_back(box("jamb_right", V(half_open, -t, 0), V(half_open + jamb, t, wall_h), kWall));
  m.parts.push_back(box("lintel", V(-half_open, -t, open_h), V(half_open, t, wall_h), kWall));
  m.parts.push_back(box("mark_frame_left", V(-half_open - 0.01f, -t - 0.01f, 0), V(-half_open + 0.1f, t + 0.01f, open_h),
                        kSafetyYellow));
  m.parts.push_back(box("mark_frame_right", V(half_open - 0.1f, -t - 0.01f, 0), V(half_open + 0.01f, t + 0.01f, open_h),
                        kSafetyYellow));
  return m;
}

// A loading-dock platform 3 x 3 x 1.2 m; its +x face meets the lorry, with rubber bumpers, a
// guard rail along each side edge (1 m high) and a dock plate (drawn only) reaching over the
// bumpers onto the lorry's bed.
MeshSpec dock() {
  MeshSpec m{"dock.obj", {}};
  const float h = 1.5f, top = 1.2f, rail = 0.08f, rail_top = top + 1.0f;
  m.parts.push_back(box("platform", V(-h, -h, 0), V(h, h, top), kConcrete));
  m.parts.push_back(box("bumper_left", V(h, 0.7f, 0.85f), V(h + 0.1f, 1.0f, 1.15f), kRubber));
  m.parts.push_back(box("bumper_right", V(h, -1.0f, 0.85f), V(h + 0.1f, -0.7f, 1.15f), kRubber));
  m.parts.push_back(box("rail_left", V(-h, h - rail, top), V(h, h, rail_top), kSafetyYellow));
  m.parts.push_back(box("rail_right", V(-h, -h, top), V(h, -h + rail, rail_top), kSafetyYellow));
  m.parts.push_back(box("mark_dock_plate", V(h - 0.3f, -0.9f, top), V(h + 0.4f, 0.9f, top + 0.01f), kSteel));
  return m;
}

// A semi-trailer with a box body, open at the rear (-x), and its tractor's cab at the front
// (+x). Bed top 1.2 m; the origin is the middle of the whole footprint.
MeshSpec lorry() {
  MeshSpec m{"lorry.obj", {}};
  const float rear = -8.05f, body_front = 5.55f, hw = 1.25f, bed_top = 1.2f, bed = 0.2f;
  const float wall = 0.05f, roof_bottom = 3.9f, roof_top = 4.0f;
  m.parts.push_back(box("bed", V(rear, -hw, bed_top - bed), V(body_front, hw, bed_top), kDarkSteel));
  m.parts.push_back(box("body_left", V(rear, hw - wall, bed_top), V(body_front, hw, roof_bottom), kTrailerWhite));
  m.parts.push_back(box("body_right", V(rear, -hw, bed_top), V(body_front, -hw + wall, roof_bottom), kTrailerWhite));
  m.parts.push_back(box("body_front", V(body_front - wall, -hw + wall, bed_top), V(body_front, hw - wall, roof_bottom),
                        kTrailerWhite));
  m.parts.push_back(box("body_roof", V(rear, -hw, roof_bottom), V(body_front, hw, roof_top), kTrailerWhite));
  m.parts.push_back(box("chassis_frame", V(rear + 0.5f, -0.5f, 0.75f), V(body_front + 2.3f, 0.5f, bed_top - bed),
                        kDarkSteel));
  m.parts.push_back(box("landing_legs", V(0.8f, -1.0f, 0.0f), V(1.0f, 1.0f, 0.75f), kDarkSteel));
  const float r = 0.5f, tyre = 0.5f, wheel_y = hw - 0.25f;
  const float axles[] = {-6.3f, -5.0f, -3.7f, 6.3f};
  for (int a = 0; a < 4; ++a)
    for (float sy : {-1.f, 1.f})
      m.parts.push_back(cylinder_y("wheel_" + std::to_string(a) + (sy > 0 ? "_left" : "_right"),
                                   V(axles[a], sy * wheel_y, r), r, tyre, 16, kRubber));
  const float cab_back = body_front + 0.2f, cab_front = 8.05f;
  m.parts.push_back(box("cab", V(cab_back, -hw, 1.0f), V(cab_front, hw, 3.6f), kCabBlue));
  m.parts.push_back(box("mark_windscreen", V(cab_front, -hw + 0.15f, 2.3f), V(cab_front + 0.01f, hw - 0.15f, 3.3f),
                        kGlass));
  return m;
}

// A 0.75 m traffic cone: a base and three stacked, narrowing bodies, with a white band.
MeshSpec cone() {
  MeshSpec m{"cone.obj", {}};
  m.parts.push_back(box("base", V(-0.2f, -0.2f, 0), V(0.2f, 0.2f, 0.04f), kConeOrange));
  m.parts.push_back(box("body_0", V(-0.15f, -0.15f, 0.04f), V(0.15f, 0.15f, 0.3f), kConeOrange));
  m.parts.push_back(box("body_1", V(-0.11f, -0.11f, 0.3f), V(0.11f, 0.11f, 0.55f), kConeOrange));
  m.parts.push_back(box("body_2", V(-0.07f, -0.07f, 0.55f), V(0.07f, 0.07f, 0.75f), kConeOrange));
  m.parts.push_back(box("mark_band", V(-0.115f, -0.115f, 0.38f), V(0.115f, 0.115f, 0.47f), kWhite));
  return m;
}

// A standing person, 1.75 m, facing +x, in a high-visibility vest.
MeshSpec pedestrian() {
  MeshSpec m{"pedestrian.obj", {}};
  m.parts.push_back(box("leg_left", V(-0.08f, 0.02f, 0), V(0.08f, 0.17f, 0.85f), kDenim));
  m.parts.push_back(box("leg_right", V(-0.08f, -0.17f, 0), V(0.08f, -0.02f, 0.85f), kDenim));
  m.parts.push_back(box("torso", V(-0.12f, -0.21f, 0.85f), V(0.12f, 0.21f, 1.45f), kHiVis));
  m.parts.push_back(box("arm_left", V(-0.06f, 0.21f, 0.80f), V(0.06f, 0.29f, 1.42f), kHiVis));
  m.parts.push_back(box("arm_right", V(-0.06f, -0.29f, 0.80f), V(0.06f, -0.21f, 1.42f), kHiVis));
  m.parts.push_back(box("neck", V(-0.05f, -0.05f, 1.45f), V(0.05f, 0.05f, 1.52f), kSkin));
  m.parts.push_back(box("head", V(-0.10f, -0.09f, 1.52f), V(0.10f, 0.09f, 1.75f), kSkin));
  return m;
}

// --- the truck, each part in the frame BodyPoses gives for it, from its truck file ---------

// Prism sides of a tyre and of its hub: enough to look round; a multiple of 4 keeps the bounds exact.
constexpr int kTyreSides = 24, kHubSides = 12;

// Geometry frame: origin on the ground below the middle of the front axle, x forward. The body
// leaves a well around each wheel, the rear one wide enough for the wheel to turn.
MeshSpec truck_chassis(const TruckDrawing& t) {
  MeshSpec m{"truck_chassis.obj", {}};
  const TruckDrawing::Body& b = t.body;
  const float hw = b.half_width, floor = b.underside, hood = b.hood, top = b.top, front = b.front, back = b.rear;
  // Front wells: behind, inboard of and above the front wheels.
  const V& fc = b.front_well_clearance;
  const float well_front_back = t.front.centre.x() - t.front.radius - fc.x();
  const float frame_y = t.front.centre.y() - 0.5f * t.front.width - fc.y();
  const float fender = t.front.centre.z() + t.front.radius + fc.z();
  // The rear well: around the steered wheel's turning circle; the counterweight starts at its front.
  const V& rc = b.rear_well_clearance;
  const float cw_front = t.rear.centre.x() + t.rear.radius + rc.x();
  const float well_back = t.rear.centre.x() - t.rear.radius - rc.x();
  const float well_y = t.rear.centre.y() + t.rear.radius + rc.y();
  const float well_top = t.rear.centre.z() + t.rear.radius + rc.z();
  const float fx = well_front_back;
  m.parts.push_back(box("chassis_front", V(fx, -frame_y, floor), V(front, frame_y, b.front_frame_top), kTruckRed));
  m.parts.push_back(box("chassis_fender_left", V(fx, frame_y, fender), V(front, hw, b.cowl_bottom), kTruckRed));
  m.parts.push_back(box("chassis_fender_right", V(fx, -hw, fender), V(front, -frame_y, b.cowl_bottom), kTruckRed));
  m.parts.push_back(box("chassis_cowl", V(fx, -hw, b.cowl_bottom), V(front, hw, top), kTruckRed));
  m.parts.push_back(box("chassis_battery", V(cw_front, -hw, floor), V(fx, hw, hood), kTruckRed));
  m.parts.push_back(box("chassis_counterweight_left", V(back, well_y, floor), V(cw_front, hw, top), kTruckRed));
  m.parts.push_back(box("chassis_counterweight_right", V(back, -hw, floor), V(cw_front, -well_y, top), kTruckRed));
  m.parts.push_back(box("chassis_counterweight_top", V(back, -well_y, well_top), V(cw_front, well_y, top), kTruckRed));
  m.parts.push_back(box("chassis_counterweight_rear", V(back, -well_y, floor), V(well_back, well_y, well_top),
                        kTruckRed));
  const TruckDrawing::Seat& s = t.seat;
  m.parts.push_back(box("seat", V(s.rear, -s.half_width, hood), V(s.front, s.half_width, s.cushion), kSeat));
  m.parts.push_back(box("seat_back", V(s.back_rear, -s.half_width, s.cushion), V(s.back_front, s.half_width, s.back_top),
                        kSeat));
  const TruckDrawing::SteeringWheel& st = t.steering;
  m.parts.push_back(box("steering_column", V(st.column_rear, -st.column_half_width, top),
                        V(st.column_front, st.column_half_width, st.bottom), kDarkSteel));
  m.parts.push_back(box("steering_wheel", V(st.rear, -st.radius, st.bottom), V(st.front, st.radius, st.top), kDarkSteel));
  // Overhead guard: four posts, side rails and cross slats (the driver sees the rack through
  // the slats when lifting high). The front posts stand on the cowl, the rear ones on the hood.
  const TruckDrawing::Guard& g = t.guard;
  const float roof = g.roof_bottom, roof_top = g.roof_top, post = g.post, py = hw - post;
  const float pf0 = g.front_post_rear, pf1 = g.front_post_rear + post;
  m.parts.push_back(box("guard_post_front_left", V(pf0, py, top), V(pf1, hw, roof), kDarkSteel));
  m.parts.push_back(box("guard_post_front_right", V(pf0, -hw, top), V(pf1, -py, roof), kDarkSteel));
  m.parts.push_back(box("guard_post_rear_left", V(g.rear, py, hood), V(g.rear + post, hw, roof), kDarkSteel));
  m.parts.push_back(box("guard_post_rear_right", V(g.rear, -hw, hood), V(g.rear + post, -py, roof), kDarkSteel));
  m.parts.push_back(box("guard_rail_left", V(g.rear, py, roof), V(g.front, hw, roof_top), kDarkSteel));
  m.parts.push_back(box("guard_rail_right", V(g.rear, -hw, roof), V(g.front, -py, roof_top), kDarkSteel));
  const float inset = 0.5f * (roof_top - roof - g.slat_thickness);  // slats centred in the roof's depth
  for (int k = 0; k < g.slats; ++k) {
    const float x0 = g.rear + g.first_slat + k * g.slat_pitch;
    m.parts.push_back(box("guard_slat_" + std::to_string(k), V(x0, -py, roof + inset),
                          V(x0 + g.slat_width, py, roof_top - inset), kDarkSteel));
  }
  return m;
}

// Mast frame: origin at the tilt pivot. Two outer channels from the foot to the built height
// (both given above the floor), cross members, and the lift cylinder between the channels or,
// on a clear-view mast, a cylinder behind each channel, where the driver looks past it.
MeshSpec truck_mast(const TruckDrawing& t) {
  MeshSpec m{"truck_mast.obj", {}};
  const TruckDrawing::Mast& a = t.mast;
  const float x0 = a.channel_rear, x1 = a.channel_front, yi = a.channel_inner_y, yo = a.channel_outer_y;
  const float bottom = a.foot - t.mast_pivot.z(), top = a.built_height - t.mast_pivot.z();
  const float xc = x0 + a.cross_member_depth, cy = a.cylinder_half_width;
  m.parts.push_back(box("mast_left", V(x0, yi, bottom), V(x1, yo, top), kDarkSteel));
  m.parts.push_back(box("mast_right", V(x0, -yo, bottom), V(x1, -yi, top), kDarkSteel));
  m.parts.push_back(box("mast_cross_top", V(x0, -yi, top - a.top_cross_member), V(xc, yi, top), kDarkSteel));
  m.parts.push_back(box("mast_cross_middle", V(x0, -yi, a.middle_cross_member_bottom), V(xc, yi, a.middle_cross_member_top),
                        kDarkSteel));
  if (a.cylinder_axis_y > 0) {
    const float yc = a.cylinder_axis_y;
    m.parts.push_back(box("mast_cylinder_left", V(a.cylinder_rear, yc - cy, a.cylinder_bottom),
                          V(a.cylinder_front, yc + cy, a.cylinder_top), kSteel));
    m.parts.push_back(box("mast_cylinder_right", V(a.cylinder_rear, -yc - cy, a.cylinder_bottom),
                          V(a.cylinder_front, -yc + cy, a.cylinder_top), kSteel));
  } else {
    m.parts.push_back(box("mast_cylinder", V(a.cylinder_rear, -cy, a.cylinder_bottom),
                          V(a.cylinder_front, cy, a.cylinder_top), kSteel));
  }
  return m;
}

// Carriage frame: origin at the fork heel (fork face meets fork top), forks along +x with
// their top at z = 0. Plate and load backrest in front of the inner mast, which rides with the
// carriage (duplex mast without free lift) and, lowered, reaches the outer mast's built height.
MeshSpec truck_carriage(const TruckDrawing& t) {
  MeshSpec m{"truck_carriage.obj", {}};
  const TruckDrawing::Carriage& c = t.carriage;
  const float face = 0.0f, back = -c.plate_depth, hy = c.half_width, f = c.backrest_frame;
  const float plate = c.plate_height, rest = c.backrest_height;
  m.parts.push_back(box("carriage_plate", V(back, -hy, 0.0f), V(face, hy, plate), kDarkSteel));
  m.parts.push_back(box("carriage_backrest_left", V(back, hy - f, plate), V(face, hy, rest), kDarkSteel));
  m.parts.push_back(box("carriage_backrest_right", V(back, -hy, plate), V(face, -hy + f, rest), kDarkSteel));
  m.parts.push_back(box("carriage_backrest_top", V(back, -hy + f, rest - f), V(face, hy - f, rest), kDarkSteel));
  const float bar = 0.5f * c.backrest_bar_width;
  for (size_t k = 0; k < c.backrest_bars_y.size(); ++k) {
    const float y = c.backrest_bars_y[k];
    m.parts.push_back(box("carriage_backrest_bar_" + std::to_string(k), V(back, y - bar, plate),
                          V(face, y + bar, rest - f), kDarkSteel));
  }
  const float fl = t.fork_length, fw = t.fork_width, ft = t.fork_thickness, fy = 0.5f * t.fork_centres_y;
  m.parts.push_back(box("fork_left", V(face, fy - 0.5f * fw, -ft), V(face + fl, fy + 0.5f * fw, 0), kDarkSteel));
  m.parts.push_back(box("fork_right", V(face, -fy - 0.5f * fw, -ft), V(face + fl, -fy + 0.5f * fw, 0), kDarkSteel));
  const float heel_z = t.mast_pivot.z() + t.fork_heel_from_pivot.z();  // above the floor, forks lowered
  const float ix0 = c.inner_mast_rear, ix1 = c.inner_mast_front, iyi = c.inner_mast_inner_y, iyo = c.inner_mast_outer_y;
  const float itop = t.mast.built_height - heel_z, ibottom = c.inner_mast_bottom;
  m.parts.push_back(box("carriage_inner_mast_left", V(ix0, iyi, ibottom), V(ix1, iyo, itop), kDarkSteel));
  m.parts.push_back(box("carriage_inner_mast_right", V(ix0, -iyo, ibottom), V(ix1, -iyi, itop), kDarkSteel));
  m.parts.push_back(box("carriage_inner_mast_top", V(ix0, -iyi, itop - c.inner_mast_top_member), V(ix1, iyi, itop),
                        kDarkSteel));
  return m;
}

// Wheels: centred, axle along y; a tyre and a hub standing slightly proud of it.
MeshSpec wheel(const std::string& file, const TruckDrawing::Wheel& w, const TruckDrawing& t) {
  MeshSpec m{file, {}};
  m.parts.push_back(cylinder_y("tyre", V::Zero(), w.radius, w.width, kTyreSides, kRubber));
  m.parts.push_back(
      cylinder_y("hub", V::Zero(), t.hub_radius_share * w.radius, w.width + 2.0f * t.hub_proud, kHubSides, kSteel));
  return m;
}

}  // namespace

Part box(const std::string& name, const V& lo, const V& hi, const Colour& colour) {
  Part p{name, colour, {}, {}, {}};
  for (int a = 0; a < 3; ++a)
    for (float s : {-1.f, 1.f}) {
      // Tangent axes u, v with u x v = n: the corners (-u,-v), (+u,-v), (+u,+v), (-u,+v) then
      // run counter-clockwise about n. Corners are taken from lo and hi themselves, so the
      // file holds the given coordinates exactly.
      V n = V::Zero();
      n[a] = s;
      const int ua = s > 0 ? (a + 1) % 3 : (a + 2) % 3, va = s > 0 ? (a + 2) % 3 : (a + 1) % 3;
      auto corner = [&](bool u_hi, bool v_hi) {
        V c;
        c[a] = s > 0 ? hi[a] : lo[a];
        c[ua] = u_hi ? hi[ua] : lo[ua];
        c[va] = v_hi ? hi[va] : lo[va];
        return c;
      };
      add_face(p, {corner(false, false), corner(true, false), corner(true, true), corner(false, true)}, n);
    }
  return p;
}

Part cylinder_y(const std::string& name, const V& centre, float radius, float width, int sides, const Colour& colour) {
  Part p{name, colour, {}, {}, {}};
  const float hw = 0.5f * width;
  // Angles from +x towards +z; a multiple of 4 sides puts vertices on the extremes, so the
  // bounds are exact. Values are rounded to 1e-6 m so the file does not carry -0 or 1e-17.
  auto at = [&](int k, float y) {
    const double a = 2.0 * M_PI * k / sides;
    auto r6 = [](double v) { return static_cast<float>(std::round(v * 1e6) / 1e6); };
    return V(centre.x() + r6(radius * std::cos(a)), centre.y() + y, centre.z() + r6(radius * std::sin(a)));
  };
  for (int k = 0; k < sides; ++k) {
    const double mid = 2.0 * M_PI * (k + 0.5) / sides;
    const V n(static_cast<float>(std::cos(mid)), 0, static_cast<float>(std::sin(mid)));
    add_face(p, {at(k, hw), at(k + 1, hw), at(k + 1, -hw), at(k, -hw)}, n);
  }
  std::vector<V> plus, minus;
  for (int k = 0; k < sides; ++k) {
    plus.push_back(at(sides - k, hw));  // decreasing angle: counter-clockwise about +y
    minus.push_back(at(k, -hw));
  }
  add_face(p, plus, V(0, 1, 0));
  add_face(p, minus, V(0, -1, 0));
  return p;
}

std::vector<MeshSpec> all_meshes() {
  return {
      rack(),
      pallet(),
      unit_box("load_box.obj", "load", kCardboard),
      unit_box("wall.obj", "wall", kWall),
      unit_box("obstacle.obj", "obstacle", kSafetyYellow),
      door(),
      dock(),
      lorry(),
      cone(),
      pedestrian(),
  };
}

std::vector<MeshSpec> truck_meshes(const TruckDrawing& truck) {
  return {truck_chassis(truck), truck_mast(truck), truck_carriage(truck),
          wheel("truck_wheel_front.obj", truck.front, truck), wheel("truck_wheel_rear.obj", truck.rear, truck)};
}

void write_obj(const MeshSpec& spec, const std::string& dir) {
  std::string error;
  if (!mesh_files().write_obj(spec, dir, error)) throw std::runtime_error(error);
}

}  // namespace forklift::meshgen
