// The Warehouse: each tick, place the truck, find its contacts, then handle the pallets.
#include <cmath>
#include <stdexcept>

#include "collision_world.h"
#include "forklift/collision/collision.h"
#include "pallet_handling.h"

namespace forklift {
namespace {

using collision::Body;
using Eigen::Isometry3d;
using Eigen::Vector3d;

// Step for the finite difference that turns the state's rates into body velocities.
constexpr double kVelocityStepS = 1e-4;

CoordVector rates(const StateVector& x) {
  CoordVector qd;
  qd.head<kNumDynamic>() = x.segment<kNumDynamic>(StateIndex::kQdot);
  for (int d = 0; d < kNumDriven; ++d) qd[kNumDynamic + d] = x[StateIndex::kDriven + 3 * d + 1];
  return qd;
}

// Linear velocity of the origin and angular velocity of one rigid body, world.
struct Twist {
  Vector3d origin = Vector3d::Zero(), v = Vector3d::Zero(), w = Vector3d::Zero();
  Vector3d at(const Vector3d& p) const { return v + w.cross(p - origin); }
};

Twist twist(const Isometry3d& a, const Isometry3d& b, double h) {
  Twist t;
  t.origin = a.translation();
  t.v = (b.translation() - a.translation()) / h;
  const Eigen::AngleAxisd d(b.linear() * a.linear().transpose());
  t.w = d.axis() * d.angle() / h;
  return t;
}

Isometry3d yaw_pose(const Vector3d& at, double yaw) {
  Isometry3d p = Isometry3d::Identity();
  p.translation() = at;
  p.linear() = Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
  return p;
}

double yaw_of(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

// The lowest corner of a pallet's underside, world z.
double underside(const Isometry3d& pose, const PalletSpec& s) {
  double z = 1e9;
  for (double sx : {-0.5, 0.5})
    for (double sy : {-0.5, 0.5}) z = std::min(z, (pose * Vector3d(sx * s.length_m, sy * s.width_m, 0)).z());
  return z;
}

Isometry3d along_x(double s) {
  Isometry3d t = Isometry3d::Identity();
  t.translation().x() = s;
  return t;
}

}  // namespace

const char* handling_event_name(HandlingEvent::Kind kind) {
  switch (kind) {
    case HandlingEvent::Kind::kPickedUp: return "picked_up";
    case HandlingEvent::Kind::kSetDown: return "set_down";
    case HandlingEvent::Kind::kSliding: return "sliding";
    case HandlingEvent::Kind::kDropped: return "dropped";
  }
  return "?";
}

// What handling remembers from tick to tick: where every pallet is, the one on the forks and how
// it sits there. A copyable value (part of a session's state).
struct HandlingState::Data {
  bool primed = false;  // false: a state never stepped, which starts as the scene puts the pallets
  std::vector<PalletState> states;  // per pallet (index into these, not into scene.objects)
  std::vector<bool> pick_armed, engaged;
  std::vector<handling::Engagement> engagement;

  // The carried pallet. How it slides and whether it falls is the truck model's (the load on the
  // forks, Simulation::load_on_forks): read here each tick.
  int carried = -1;
  Isometry3d rel = Isometry3d::Identity();  // carriage from pallet, before sliding
  double slide_m = 0, slide_rate_m_s = 0;
  int slips_seen = 0;  // the model's slips already told as `sliding` events
  double pickup_underside_z = 0;
  bool lifted_clear = false;
};

HandlingState::HandlingState() : d_(std::make_unique<Data>()) {}
HandlingState::HandlingState(const HandlingState& o) : d_(std::make_unique<Data>(*o.d_)) {}
HandlingState& HandlingState::operator=(const HandlingState& o) {
  *d_ = *o.d_;
  return *this;
}
HandlingState::HandlingState(HandlingState&&) noexcept = default;
HandlingState& HandlingState::operator=(HandlingState&&) noexcept = default;
HandlingState::~HandlingState() = default;
const std::vector<PalletState>& HandlingState::pallets() const { return d_->states; }
const PalletState* HandlingState::pallet(const std::string& id) const {
  for (const PalletState& s : d_->states)
    if (s.id == id) return &s;
  return nullptr;
}

void apply(const StepReport& r, Simulation& sim) {
  sim.set_external_forces(r.scene_push);
  if (r.load_change == LoadChange::kAttached) sim.attach_load(r.load);
  if (r.load_change == LoadChange::kReleased) sim.release_load();
}

// The scene's collision shapes and the handling rules; the state it works on is its base,
// swapped with a session's own for the length of a step.
struct Warehouse::Impl : HandlingState::Data {
  Scene scene;  // a copy: supports, ground and ids are read every tick
  TruckParams truck;
  std::array<collision::LocalBox, 2> forks;
  double fork_tip_x = 0;  // the forks' tips, carriage frame

  std::vector<int> pallet_objects;  // the scene objects that are handled pallets
  // Where the collision world stands each pallet: a state's own poses (a rewind's, a fallen
  // pallet's) are put there before each step.
  std::vector<Isometry3d> world_poses;

  std::unique_ptr<collision::CollisionWorld> world;

  StepReport report;
  std::vector<collision::RawContact> raw;
  std::vector<collision::LocalBox> people_boxes;       // scratch, per pedestrian then per other truck
  const std::vector<PedestrianState>* people = nullptr;  // this step's, when the scene has any
  const std::vector<OtherTruckState>* trucks = nullptr;  // this step's, when the scene has any
  size_t people_placed = 0;                              // the first people_boxes are people, the rest trucks

  Impl(const Scene& s, const TruckShape& shape, const TruckParams& t) : scene(s), truck(t) {
    forks = collision::fork_boxes(shape);
    for (const auto& f : forks) fork_tip_x = std::max(fork_tip_x, f.centre.translation().x() + f.half.x());
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      const SceneObject& o = scene.objects[i];
      // A pallet without a spec has no pockets to handle: it stays a static obstacle.
      if (o.kind != ObjectKind::kPallet || !o.pallet || !o.collidable) continue;
      pallet_objects.push_back(int(i));
      PalletState st;
      st.id = o.id;
      st.pose = o.pose;
      // Where the scenario file stood it; a scene built in code is searched for a support.
      if (!o.rests_on.empty()) {
        st.resting_on = o.rests_on;
        st.level = o.rest_level;
      } else {
        rest_on_support(st);
      }
      states.push_back(st);
    }
    pick_armed.assign(states.size(), false);
    engaged.assign(states.size(), false);
    engagement.assign(states.size(), {});
    world = collision::make_collision_world(scene, shape, pallet_objects);
    for (const PalletState& st : states) world_poses.push_back(st.pose);
  }

  void stand_pallets() {
    for (size_t p = 0; p < states.size(); ++p)
      if (int(p) != carried && !world_poses[p].isApprox(states[p].pose, 0.0)) {
        world->set_pallet_pose(int(p), states[p].pose);
        world_poses[p] = states[p].pose;
      }
  }

  const PalletSpec& spec(int p) const { return *scene.objects[pallet_objects[p]].pallet; }

  // What a pallet stands on, from where it is: the support within a few centimetres of its underside.
  void rest_on_support(PalletState& st) const {
    const Vector3d c = st.pose.translation();
    double best = -1e9;
    st.resting_on.clear();
    st.level = 0;
    for (const SceneObject& o : scene.objects) {
      const Vector3d pl = o.pose.inverse() * c;
      for (const Support& s : o.supports) {
        if (!s.footprint.contains(pl.head<2>())) continue;
        const double z = (o.pose * Vector3d(pl.x(), pl.y(), s.height_m)).z();
        if (std::abs(c.z() - z) <= handling::kSupportWindowM && z > best) {
          best = z;
          st.resting_on = o.id;
          st.level = s.level;
        }
      }
    }
  }

  Isometry3d load_pose(const Isometry3d& carriage) const { return carriage * along_x(slide_m) * rel; }

  // The people's bodies, then the other trucks', where this step's states stand them (none
  // without states: nobody to strike, as in contacts_at).
  void place_people() {
    if (scene.pedestrians.empty() && scene.trucks.empty()) return;
    people_placed = people ? scene.pedestrians.size() : 0;
    people_boxes.resize(people_placed + (trucks ? scene.trucks.size() : 0));
    for (size_t i = 0; i < people_placed; ++i) {
      const PedestrianSpec& spec = scene.pedestrians[i];
      // Local x chest to back, y across the shoulders (pedestrian_body_pose).
      people_boxes[i] = {pedestrian_body_pose(spec, (*people)[i]), 0.5 * Vector3d(spec.size_m.y(), spec.size_m.x(), spec.size_m.z())};
    }
    for (size_t i = people_placed; i < people_boxes.size(); ++i) {
      const OtherTruckSpec& spec = scene.trucks[i - people_placed];
      people_boxes[i] = {other_truck_pose(spec, (*trucks)[i - people_placed]), 0.5 * spec.size_m};
    }
    world->place_people(people_boxes);
  }

  // Truck placed at q: engagement of the nearby pallets, then the contacts.
  void place_and_collide(const BodyPoses& poses) {
    world->place_truck(poses, carried >= 0 ? load_pose(poses.carriage) : Isometry3d::Identity());
    place_people();
    std::fill(engaged.begin(), engaged.end(), false);
    for (int p : world->nearby_pallets()) {
      engagement[p] = handling::engagement(spec(p), states[p].pose.inverse() * poses.carriage, forks);
      engaged[p] = engagement[p].engaged;
    }
    world->contacts(engaged, raw);
  }

  void to_contacts(const std::array<Twist, 3>* motion, const Vector3d& fork_x, std::vector<Contact>& out) const {
    out.clear();
    for (const collision::RawContact& r : raw) {
      // A carried load a little into the surface below it rests there: just picked up, with the
      // truck settling under the new weight, or being set down. Not a strike.
      if (r.body == Body::kLoad && r.normal.z() > 0.9 && r.depth <= handling::kRestingTouchDepthM) continue;
      Contact c;
      c.truck_part = collision::part_name(r.part);
      Vector3d person_v = Vector3d::Zero();
      if (r.person >= int(people_placed)) {
        const int t = r.person - int(people_placed);
        c.object_id = scene.trucks[t].id;
        c.object_kind = ObjectKind::kObstacle;  // pushes back as one
        c.other_truck = t;
        const OtherTruckState& o = (*trucks)[t];
        person_v = o.speed_m_s * Vector3d(std::cos(o.heading_rad), std::sin(o.heading_rad), 0);
      } else if (r.person >= 0) {
        c.object_id = scene.pedestrians[r.person].id;
        c.object_kind = ObjectKind::kPedestrian;
        c.pedestrian = r.person;
        const PedestrianState& p = (*people)[r.person];
        person_v = p.speed_m_s * Vector3d(std::cos(p.heading_rad), std::sin(p.heading_rad), 0);
      } else {
        const SceneObject& o = scene.objects[r.object];
        c.object_id = o.id;
        c.object_kind = o.kind;
      }
      c.point_m = r.point;
      c.normal = r.normal;
      c.depth_m = r.depth;
      if (motion) {
        const int b = r.body == Body::kChassis ? 0 : r.body == Body::kMast ? 1 : 2;
        Vector3d v = (*motion)[b].at(r.point);
        if (r.body == Body::kLoad) v += slide_rate_m_s * fork_x;
        c.relative_speed_m_s = std::max(0.0, -(v - person_v).dot(r.normal));
      }
      out.push_back(std::move(c));
    }
  }

  void event(HandlingEvent::Kind kind, int p, const std::string& on = "", int level = 0) {
    report.handling.push_back({kind, states[p].id, on, level, states[p].pose.translation()});
  }

  void attach(const Load& load) {
    report.load_change = LoadChange::kAttached;
    report.load = load;
  }

  void pick_up(int p, const Isometry3d& carriage) {
    PalletState& st = states[p];
    const PalletSpec& s = spec(p);
    // Fixed to the carriage from now on, as it stands at this instant: its deck's underside has
    // just met the forks' highest point, so nothing jumps. (Snapping it flat onto the forks
    // would push one end into its support when the truck leans or the mast is tilted; the
    // small relative tilt it keeps instead is undone when it is set down level.)
    rel = carriage.inverse() * st.pose;
    slide_m = slide_rate_m_s = 0;
    slips_seen = 0;
    pickup_underside_z = underside(st.pose, s);
    lifted_clear = false;
    attach(handling::pallet_load(s, rel));
    carried = p;
    world->set_carried(p);
    st.pose = load_pose(carriage);
    st.on_forks = true;
    st.dropped = false;
    st.slide_m = 0;
    st.resting_on.clear();
    st.level = 0;
    pick_armed[p] = false;
    event(HandlingEvent::Kind::kPickedUp, p);
  }

  void put_down(const Isometry3d& pose, bool dropped, const std::string& on, int level) {
    const int p = carried;
    PalletState& st = states[p];
    report.load_change = LoadChange::kReleased;
    carried = -1;
    world->set_carried(-1);
    world->set_pallet_pose(p, pose);
    world_poses[p] = pose;
    st.pose = pose;
    st.on_forks = false;
    st.dropped = dropped;
    st.resting_on = on;
    st.level = level;
    pick_armed[p] = false;  // the forks are still in its pockets, at its deck
    event(dropped ? HandlingEvent::Kind::kDropped : HandlingEvent::Kind::kSetDown, p, on, level);
  }

  void handle_carried(const Simulation& sim, const BodyPoses& poses, const std::array<Twist, 3>& motion) {
    PalletState& st = states[carried];
    const PalletSpec& s = spec(carried);
    const Isometry3d& C = poses.carriage;
    const Vector3d fork_x = C.linear().col(0);
    const LoadOnForks& held = sim.load_on_forks();

    // Fallen off the forks (past the tips, or with the truck gone over): on the floor below where
    // its centre of gravity left them.
    if (held.phase == LoadPhase::kFallen) {
      const Vector3d& c = held.fell_at_m;
      put_down(yaw_pose(Vector3d(c.x(), c.y(), scene.ground.height(c.x(), c.y())), yaw_of(load_pose(C).linear())),
               true, "", 0);
      return;
    }
    if (held.slips > slips_seen) event(HandlingEvent::Kind::kSliding, carried);
    slips_seen = held.slips;
    st.pose = load_pose(C);
    st.slide_m = slide_m;

    // Set down: lowered onto a support under its centre, or onto the floor.
    const double low = underside(st.pose, s);
    if (low >= pickup_underside_z + handling::kLiftedClearM) lifted_clear = true;
    const Vector3d centre = st.pose.translation();
    const bool descending = motion[2].at(centre).z() + slide_rate_m_s * fork_x.z() < 0;
    const bool may_land = descending && (lifted_clear || low <= pickup_underside_z - handling::kSinkM);
    if (may_land) {
      double best = -1e9;
      const SceneObject* on = nullptr;
      int level = 0;
      for (const SceneObject& o : scene.objects) {
        if (o.supports.empty()) continue;
        const Vector3d pl = o.pose.inverse() * centre;
        for (const Support& sp : o.supports) {
          if (!sp.footprint.contains(pl.head<2>())) continue;
          const double z = (o.pose * Vector3d(pl.x(), pl.y(), sp.height_m)).z();
          if (low <= z + handling::kTouchM && low >= z - handling::kSupportWindowM && z > best) {
            best = z;
            on = &o;
            level = sp.level;
          }
        }
      }
      const double floor = scene.ground.height(centre.x(), centre.y());
      const bool on_floor = !on && low <= floor + handling::kTouchM;
      if (on_floor) best = floor;
      if (on || on_floor) {
        put_down(yaw_pose(Vector3d(centre.x(), centre.y(), best), yaw_of(st.pose.linear())), false,
                 on ? on->id : "", level);
        return;
      }
    }
  }

  void handle_free(const Simulation& sim, const Isometry3d& carriage) {
    for (int p : world->nearby_pallets()) {
      const handling::Engagement& e = engagement[p];
      const PalletSpec& s = spec(p);
      if (!e.engaged) { pick_armed[p] = false; continue; }
      if (e.fork_top_m <= s.pocket_top_m - handling::kPickArmClearanceM) pick_armed[p] = true;
      // One load at a time: not while the truck carries one (a scenario's load included).
      if (pick_armed[p] && e.fork_top_m > s.pocket_top_m && carried < 0 && !sim.load()) {
        pick_up(p, carriage);
        return;
      }
    }
  }

  // Fixed objects push back where the truck is inside them: a penalty force held for the next
  // tick. Light ones (cones, pallets) and people get none: they would give way, and the
  // evaluation counts the strike.
  void push_back() {
    for (const Contact& c : report.contacts) {
      switch (c.object_kind) {
        case ObjectKind::kRack: case ObjectKind::kWall: case ObjectKind::kDoor:
        case ObjectKind::kDock: case ObjectKind::kLorry: case ObjectKind::kObstacle: break;
        default: continue;
      }
      const TruckBody body = c.truck_part == "chassis" || c.truck_part == "guard" ? TruckBody::kChassis
                             : c.truck_part == "mast"                             ? TruckBody::kMast
                                                                                  : TruckBody::kCarriage;
      const SceneContactParams& k = truck.scene_contact;
      const double f = k.stiffness_N_m * c.depth_m + k.damping_N_s_m * c.relative_speed_m_s;
      report.scene_push.push_back({body, c.point_m, f * c.normal});
    }
  }

  const StepReport& step(const Simulation& sim) {
    report.contacts.clear();
    report.handling.clear();
    report.scene_push.clear();
    report.load_change = LoadChange::kNone;
    if (carried >= 0) {
      slide_m = sim.load_on_forks().slide_m;
      slide_rate_m_s = sim.load_on_forks().slide_rate_m_s;
    }

    const StateVector& x = sim.state();
    const CoordVector q = coordinates(x);
    const BodyPoses poses = body_poses(truck, q);
    stand_pallets();
    place_and_collide(poses);

    // Body velocities, only when something needs them.
    std::array<Twist, 3> motion;
    const bool moving = !raw.empty() || carried >= 0;
    if (moving) {
      const double h = kVelocityStepS;
      const BodyPoses ahead = body_poses(truck, q + h * rates(x));
      motion = {twist(poses.chassis, ahead.chassis, h), twist(poses.mast, ahead.mast, h),
                twist(poses.carriage, ahead.carriage, h)};
    }
    to_contacts(moving ? &motion : nullptr, poses.carriage.linear().col(0), report.contacts);
    push_back();

    if (carried >= 0) handle_carried(sim, poses, motion);
    else handle_free(sim, poses.carriage);
    return report;
  }

  std::vector<Contact> contacts_at(const CoordVector& q) {
    const BodyPoses poses = body_poses(truck, q);
    place_and_collide(poses);
    std::vector<Contact> out;
    to_contacts(nullptr, poses.carriage.linear().col(0), out);
    return out;
  }
};

Warehouse::Warehouse(const Scene& scene, const TruckShape& shape, const TruckParams& truck)
    : impl_(std::make_unique<Impl>(scene, shape, truck)) {
  *initial_.d_ = static_cast<const HandlingState::Data&>(*impl_);
  initial_.d_->primed = true;
}
Warehouse::~Warehouse() = default;

const StepReport& Warehouse::step(const Simulation& sim, HandlingState& state, const std::vector<PedestrianState>& people,
                                  const std::vector<OtherTruckState>& trucks) {
  if (people.size() != impl_->scene.pedestrians.size() && !people.empty())
    throw std::logic_error("Warehouse::step: one pedestrian state per scene pedestrian");
  if (trucks.size() != impl_->scene.trucks.size() && !trucks.empty())
    throw std::logic_error("Warehouse::step: one truck state per scene truck");
  // Read during this step only.
  struct People {
    const std::vector<PedestrianState>*& p;
    const std::vector<OtherTruckState>*& t;
    ~People() { p = nullptr; t = nullptr; }
  } hold{impl_->people, impl_->trucks};
  impl_->people = people.empty() ? nullptr : &people;
  impl_->trucks = trucks.empty() ? nullptr : &trucks;
  // The session's state in the warehouse for the step, and back afterwards (an exception too).
  struct Borrow {
    HandlingState::Data& mine;
    HandlingState::Data& theirs;
    ~Borrow() { std::swap(mine, theirs); }
  } b{*impl_, *state.d_};
  if (!state.d_->primed) *state.d_ = *initial_.d_;
  std::swap(b.mine, b.theirs);
  return impl_->step(sim);
}
std::vector<Contact> Warehouse::contacts_at(const CoordVector& q) { return impl_->contacts_at(q); }

bool Warehouse::move_pallet(HandlingState& state, const std::string& id, const Isometry3d& pose) const {
  if (!state.d_->primed) *state.d_ = *initial_.d_;
  HandlingState::Data& d = *state.d_;
  for (size_t p = 0; p < d.states.size(); ++p) {
    PalletState& st = d.states[p];
    if (st.id != id) continue;
    if (st.on_forks) return false;
    st.pose = pose;
    st.resting_on.clear();
    st.level = 0;
    st.dropped = true;
    d.pick_armed[p] = false;
    return true;
  }
  return false;
}

}  // namespace forklift
