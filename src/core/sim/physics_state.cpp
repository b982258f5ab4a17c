// Saved states: the world's whole state as exact JSON text, and back (checkpoints) (physics_world.h).
#include <ode/ode.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "physics_internal.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

using namespace physics_detail;

namespace {

using Json = nlohmann::json;

/// A finite number at @p key of @p object, for restoreState's sentences.
double stateNumber(const Json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number()) {
    throw ValidationError("the world state has no number '" + std::string(key) + "' in " + where);
  }
  const double value = it->get<double>();
  if (!std::isfinite(value)) throw ValidationError("the world state's " + where + "." + key + " is not finite");
  return value;
}

template <std::size_t N>
std::array<double, N> stateVector(const Json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_array() || it->size() != N) {
    throw ValidationError("the world state's " + where + "." + key + " is not a list of " + std::to_string(N) +
                          " numbers");
  }
  std::array<double, N> values{};
  for (std::size_t k = 0; k < N; ++k) {
    if (!(*it)[k].is_number() || !std::isfinite((*it)[k].get<double>())) {
      throw ValidationError("the world state's " + where + "." + key + "[" + std::to_string(k) +
                            "] is not a finite number");
    }
    values[k] = (*it)[k].get<double>();
  }
  return values;
}

std::uint64_t stateCount(const Json& object, const char* key, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number_unsigned()) {
    throw ValidationError("the world state has no whole number '" + std::string(key) + "' in " + where);
  }
  return it->get<std::uint64_t>();
}

Json parseState(const std::string& text) {
  Json state;
  try {
    state = Json::parse(text);
  } catch (const Json::exception& e) {
    throw ValidationError(std::string("the world state is not JSON: ") + e.what());
  }
  if (!state.is_object()) throw ValidationError("the world state is not a JSON object");
  return state;
}

/// Throws unless the state is of the world @p spec describes, taken with its physics step.
void checkStateWorld(Json& state, const WorldSpec& spec) {
  const auto world = state.find("world");
  if (world == state.end() || !world->is_string() || world->get<std::string>() != spec.name) {
    throw ValidationError("the world state is of world '" + (world != state.end() && world->is_string() ? world->get<std::string>() : std::string("?")) +
                          "', not of '" + spec.name + "'");
  }
  if (stateNumber(state, "step", "the state") != spec.physics.step) {
    throw ValidationError("the world state was taken with a physics step of " +
                          describeNumber(state["step"].get<double>()) + " s, this world steps " +
                          describeNumber(spec.physics.step) + " s");
  }
}

/// A state's clock, seeds, wheels, odometry and blow-up bookkeeping, checked.
struct SavedClock {
  double time;
  std::uint64_t steps, solver_seed, redraw_seed;
  std::array<double, 2> commands, angles;
  std::array<double, 5> odometry;
  double fall_height;
  std::uint64_t blow_ups;
};

SavedClock readClock(const Json& state) {
  SavedClock c;
  c.time = stateNumber(state, "time", "the state");
  c.steps = stateCount(state, "steps", "the state");
  c.solver_seed = stateCount(state, "solver_seed", "the state");
  c.redraw_seed = stateCount(state, "redraw_seed", "the state");
  c.commands = stateVector<2>(state, "wheel_commands", "the state");
  c.angles = stateVector<2>(state, "wheel_angles", "the state");
  c.odometry = stateVector<5>(state, "odometry", "the state");
  c.fall_height = stateNumber(state, "fall_height", "the state");
  c.blow_ups = stateCount(state, "blow_ups_in_a_row", "the state");
  return c;
}

/// Each body's state, checked against the world's bodies, named @p names in body order.
std::vector<BodyState> readBodies(const Json& state, const std::vector<std::string>& names) {
  const auto bodies = state.find("bodies");
  if (bodies == state.end() || !bodies->is_array() || bodies->size() != names.size()) {
    throw ValidationError("the world state does not have this world's " + std::to_string(names.size()) + " bodies");
  }
  std::vector<BodyState> body_states(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    const Json& body = (*bodies)[i];
    const std::string& name = names[i];
    if (!body.is_object() || !body.contains("name") || body["name"] != name) {
      throw ValidationError("the world state's body " + std::to_string(i) + " is not " + name);
    }
    const auto p = stateVector<3>(body, "position", name), v = stateVector<3>(body, "linear", name),
               a = stateVector<3>(body, "angular", name);
    const auto q = stateVector<4>(body, "orientation", name);
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (std::fabs(norm - 1) > 1e-6) throw ValidationError("the world state's " + name + ".orientation is not a unit quaternion");
    BodyState& s = body_states[i];
    std::copy(p.begin(), p.end(), s.position);
    std::copy(q.begin(), q.end(), s.orientation);
    std::copy(v.begin(), v.end(), s.linear);
    std::copy(a.begin(), a.end(), s.angular);
  }
  return body_states;
}

/// Each object's frictions and contact episodes, checked against the world's @p objects.
std::vector<ObjectState> readObjects(const Json& state,
                                     const std::vector<std::pair<std::string, dBodyID>>& world_objects) {
  const auto objects = state.find("objects");
  if (objects == state.end() || !objects->is_array() || objects->size() != world_objects.size()) {
    throw ValidationError("the world state does not have this world's " + std::to_string(world_objects.size()) +
                          " objects");
  }
  std::vector<ObjectState> object_states(world_objects.size());
  for (std::size_t i = 0; i < world_objects.size(); ++i) {
    const Json& object = (*objects)[i];
    const std::string& name = world_objects[i].first;
    if (!object.is_object() || !object.contains("name") || object["name"] != name) {
      throw ValidationError("the world state's object " + std::to_string(i) + " is not " + name);
    }
    const auto friction = stateVector<2>(object, "friction", name);
    if (friction[0] < 0 || friction[1] < 0) throw ValidationError("the world state's " + name + ".friction is negative");
    object_states[i].friction_x = friction[0];
    object_states[i].friction_y = friction[1];
    object_states[i].episodes = static_cast<int>(stateCount(object, "episodes", name));
    object_states[i].last_touch = stateNumber(object, "last_touch", name);
  }
  return object_states;
}

void setBodyStates(const std::vector<dBodyID>& order, const std::vector<BodyState>& body_states) {
  for (std::size_t i = 0; i < order.size(); ++i) {
    const BodyState& s = body_states[i];
    dBodySetPosition(order[i], s.position[0], s.position[1], s.position[2]);
    dBodySetQuaternion(order[i], s.orientation);
    dBodySetLinearVel(order[i], s.linear[0], s.linear[1], s.linear[2]);
    dBodySetAngularVel(order[i], s.angular[0], s.angular[1], s.angular[2]);
    dBodySetForce(order[i], 0, 0, 0);
    dBodySetTorque(order[i], 0, 0, 0);
  }
}

// ODE moves a geom to the front of its space's list when it first moves after a collision pass, so the list's
// order (and with it the order of contacts, which the solver's result depends on) is a record of history.
// Re-adding the bodies' geoms in body order and computing every bounding box makes it a function of the
// spec alone.
void canonicalGeomOrder(dSpaceID space, const std::vector<dBodyID>& order) {
  for (dBodyID b : order) {
    for (dGeomID g = dBodyGetFirstGeom(b); g; g = dBodyGetNextGeom(g)) {
      if (dGeomGetSpace(g) != space) continue;
      dSpaceRemove(space, g);
      dSpaceAdd(space, g);
    }
  }
  dSpaceClean(space);
}

}  // namespace

std::string PhysicsWorld::saveState() const {
  const Impl& w = *impl_;
  // nlohmann writes the shortest text that reads back as the same double, so numbers survive bit for bit.
  Json state;
  state["world"] = spec_.name;
  state["step"] = spec_.physics.step;
  state["time"] = w.time;
  state["steps"] = w.steps;
  state["solver_seed"] = static_cast<std::uint64_t>(w.random_seed);
  state["redraw_seed"] = redraw_seed_;
  state["wheel_commands"] = {w.left_command, w.right_command};
  state["wheel_angles"] = {w.left_angle, w.right_angle};
  state["odometry"] = {w.odometry.x, w.odometry.y, w.odometry.yaw, w.odometry.linear, w.odometry.angular};
  state["fall_height"] = w.fall_height;
  state["blow_ups_in_a_row"] = w.blow_ups_in_a_row;
  Json bodies = Json::array();
  w.forEachBody([&](dBodyID b) {
    const dReal* p = dBodyGetPosition(b);
    const dReal* q = dBodyGetQuaternion(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* a = dBodyGetAngularVel(b);
    bodies.push_back({{"name", w.bodyName(b)},
                      {"position", {p[0], p[1], p[2]}},
                      {"orientation", {q[0], q[1], q[2], q[3]}},
                      {"linear", {v[0], v[1], v[2]}},
                      {"angular", {a[0], a[1], a[2]}}});
  });
  state["bodies"] = bodies;
  Json objects = Json::array();
  for (std::size_t i = 0; i < w.objects.size(); ++i) {
    const ObjectState& o = w.object_states[i];
    objects.push_back({{"name", w.objects[i].first},
                       {"friction", {o.friction_x, o.friction_y}},
                       {"episodes", o.episodes},
                       {"last_touch", o.last_touch}});
  }
  state["objects"] = objects;
  return state.dump();
}

void PhysicsWorld::restoreState(const std::string& text) {
  Impl& w = *impl_;
  Json state = parseState(text);
  // Everything is read and checked before anything changes.
  checkStateWorld(state, spec_);
  const SavedClock clock = readClock(state);
  std::vector<dBodyID> order;
  w.forEachBody([&](dBodyID b) { order.push_back(b); });
  std::vector<std::string> names;
  for (dBodyID b : order) names.push_back(w.bodyName(b));
  const std::vector<BodyState> body_states = readBodies(state, names);
  const std::vector<ObjectState> object_states = readObjects(state, w.objects);

  setBodyStates(order, body_states);
  canonicalGeomOrder(w.space, order);
  w.time = clock.time;
  w.steps = clock.steps;
  w.random_seed = static_cast<unsigned long>(clock.solver_seed);
  setRedrawSeed(clock.redraw_seed);
  w.left_command = clock.commands[0];
  w.right_command = clock.commands[1];
  w.left_angle = clock.angles[0];
  w.right_angle = clock.angles[1];
  w.odometry = {clock.odometry[0], clock.odometry[1], clock.odometry[2], clock.odometry[3], clock.odometry[4]};
  w.object_states = object_states;
  w.fall_height = clock.fall_height;
  w.blow_ups_in_a_row = static_cast<int>(clock.blow_ups);
  w.pending.clear();
  w.saveGoodState();
  known_state_ = text;
}

std::string PhysicsWorld::checkpoint() {
  // Unchanged since a restore or a checkpoint: that state is this world exactly. Restoring it once more could
  // move the last bit of a quaternion (ODE renormalises), and a run checkpointed twice at one step (resumed
  // after its knowledge base refused the first) would go on from another world than an uninterrupted one.
  if (!known_state_.empty()) return known_state_;
  const std::string state = saveState();
  restoreState(state);
  return state;
}

}  // namespace xpersif::core
