// Contacts and friction: the collision pass, the objects' contact episodes with the robot and their redrawn
// frictions, and the friction law at each contact (physics_world.h).
#include <ode/ode.h>

#include <cmath>
#include <string>

#include "physics_internal.h"
#include "xpersif/core/common/random_stream.h"
#include "xpersif/core/common/validation.h"

namespace xpersif::core {

using namespace physics_detail;

namespace {

/// The contact's slip: the velocity of body a relative to body b at the contact point, in the contact plane.
Eigen::Vector3d slipOf(const PendingContact& p, const Eigen::Vector3d& n) {
  const dContactGeom& g = p.contact.geom;
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  dVector3 pv;
  if (p.a) {
    dBodyGetPointVel(p.a, g.pos[0], g.pos[1], g.pos[2], pv);
    v += Eigen::Vector3d(pv[0], pv[1], pv[2]);
  }
  if (p.b) {
    dBodyGetPointVel(p.b, g.pos[0], g.pos[1], g.pos[2], pv);
    v -= Eigen::Vector3d(pv[0], pv[1], pv[2]);
  }
  return v - v.dot(n) * n;
}

/// One friction axis (unit, in the contact plane) with coefficient @p mu and none across it.
void frictionAlong(PendingContact& p, const Eigen::Vector3d& d, double mu) {
  dSurfaceParameters& surface = p.contact.surface;
  surface.mode |= dContactMu2 | dContactFDir1;
  surface.mu = mu;
  surface.mu2 = 0;
  p.contact.fdir1[0] = d.x();
  p.contact.fdir1[1] = d.y();
  p.contact.fdir1[2] = d.z();
}

}  // namespace

double redrawnFriction(const ObjectSpec& object, std::uint64_t seed, std::size_t object_index, int episode) {
  const std::uint64_t h = streamSeed(seed, object_index, static_cast<std::uint64_t>(episode), StreamPurpose::Friction);
  const double u = static_cast<double>(h >> 11) * 0x1.0p-53;  // uniform in [0, 1), the same on every platform
  return object.friction_redraw_min * std::pow(object.friction_redraw_max / object.friction_redraw_min, u);
}

void PhysicsWorld::Impl::nearCallback(void* data, dGeomID a, dGeomID b) {
  auto* self = static_cast<Impl*>(data);
  dBodyID ba = dGeomGetBody(a), bb = dGeomGetBody(b);
  if (ba && bb && dAreConnectedExcluding(ba, bb, dJointTypeContact)) return;
  if (ba == bb) return;
  const auto* ia = static_cast<const GeomInfo*>(dGeomGetData(a));
  const auto* ib = static_cast<const GeomInfo*>(dGeomGetData(b));
  if (ia && ib && ia->robot && ib->robot) return;  // the robot does not collide with itself
  dContact contact[kMaxContacts];
  const int n = dCollide(a, b, kMaxContacts, &contact[0].geom, sizeof(dContact));
  if (n > 0 && ia && ib && (ia->robot || ib->robot)) {
    const GeomInfo* other = ia->robot ? ib : ia;
    if (other->object >= 0) self->object_states[other->object].touched = true;
  }
  for (int i = 0; i < n; ++i) self->pending.push_back({contact[i], ba, bb, ia, ib});
}

double PhysicsWorld::Impl::isotropicFriction(const GeomInfo* info) const {
  if (!info) return 1.0;
  if (info->object < 0) return info->friction;
  const ObjectState& s = object_states[info->object];
  return s.friction_x == s.friction_y ? s.friction_x : std::sqrt(s.friction_x * s.friction_y);
}

void PhysicsWorld::Impl::updateContactEpisodes() {
  for (std::size_t i = 0; i < object_states.size(); ++i) {
    ObjectState& s = object_states[i];
    if (!s.touched) continue;
    s.touched = false;
    const bool new_episode = s.last_touch < 0 || time - s.last_touch > spec.physics.contact_episode_gap;
    s.last_touch = time;
    if (!new_episode) continue;
    ++s.episodes;
    const ObjectSpec& o = spec.objects[i];
    if (!o.redrawn()) continue;
    s.friction_x = s.friction_y = redrawnFriction(o, redraw_seed, i, s.episodes);
  }
}

/**
 * Friction at one of the step's contacts.
 *
 * ODE's friction is a pyramid: two axes in the contact plane, each holding up to mu times the normal force on
 * its own. A contact sliding along one axis can then still hold a force across it, which no real contact does:
 * a box pushed off its centre, sliding along the push, resists turning with friction across the slide and
 * turns a tenth of what a real one does (bench/contact.md). With physics.friction_model coulomb, at every
 * contact of an object that slips, the friction is what Coulomb's law gives: mu times the normal force against
 * the slip, nothing across it (one axis along the slip, the other free); a contact at rest keeps the pyramid,
 * which holds it. An object whose friction differs along its x and y axes (runners, grain) has an elliptic
 * limit, (Fx/mu_x)^2 + (Fy/mu_y)^2 <= N^2 in its own axes; sliding, the force is the point of the ellipse that
 * opposes the slip most (maximum dissipation), F ~ -(mu_x^2 vx, mu_y^2 vy); at rest, a pyramid along its axes.
 * The robot's own contacts with the floor (wheels, sliders) always keep ODE's pyramid.
 */
void PhysicsWorld::Impl::setFriction(PendingContact& p) const {
  dSurfaceParameters& surface = p.contact.surface;
  surface.mode = dContactApprox1 | dContactSoftERP | dContactSoftCFM;
  surface.soft_erp = 0.4;
  surface.soft_cfm = 1e-5;
  surface.mu = std::sqrt(isotropicFriction(p.ia) * isotropicFriction(p.ib));
  const bool object = (p.ia && p.ia->object >= 0) || (p.ib && p.ib->object >= 0);
  if (!object) return;
  const bool coulomb = spec.physics.friction_model == PhysicsSpec::FrictionModel::Coulomb;
  const Eigen::Vector3d n(p.contact.geom.normal[0], p.contact.geom.normal[1], p.contact.geom.normal[2]);
  const Eigen::Vector3d slip = coulomb ? slipOf(p, n) : Eigen::Vector3d::Zero();
  const bool sliding = slip.norm() >= kSlipSpeed;

  // An anisotropic object on the floor: its x axis in the contact plane (unless it stands on its end).
  const GeomInfo* floor = p.ia && p.ia->floor ? p.ia : p.ib && p.ib->floor ? p.ib : nullptr;
  const GeomInfo* other = floor == p.ia ? p.ib : p.ia;
  if (floor && other && other->object >= 0) {
    const ObjectState& s = object_states[other->object];
    if (s.friction_x != s.friction_y) {
      const dReal* r = dBodyGetRotation(floor == p.ia ? p.b : p.a);  // row-major 3x4
      const Eigen::Vector3d x_axis(r[0], r[4], r[8]);
      const Eigen::Vector3d along = x_axis - x_axis.dot(n) * n;
      if (along.norm() > 0.1) {
        const Eigen::Vector3d ex = along.normalized(), ey = n.cross(ex);
        const double mx = std::sqrt(s.friction_x * floor->friction), my = std::sqrt(s.friction_y * floor->friction);
        if (!sliding) {
          frictionAlong(p, ex, mx);
          surface.mu2 = my;
          return;
        }
        const double vx = slip.dot(ex), vy = slip.dot(ey);
        const Eigen::Vector3d force = mx * mx * vx * ex + my * my * vy * ey;
        const double mu = force.norm() / std::hypot(mx * vx, my * vy);
        frictionAlong(p, force.normalized(), mu);
        return;
      }
    }
  }
  if (sliding) frictionAlong(p, slip.normalized(), surface.mu);
}

void PhysicsWorld::Impl::createContactJoints() {
  for (PendingContact& p : pending) {
    setFriction(p);
    dJointID j = dJointCreateContact(world, contacts, &p.contact);
    dJointAttach(j, p.a, p.b);
  }
  pending.clear();
}

void PhysicsWorld::setRedrawSeed(std::uint64_t seed) {
  known_state_.clear();
  redraw_seed_ = seed;
  impl_->redraw_seed = seed;
}

double PhysicsWorld::objectFriction(const std::string& object, double* along_y) const {
  requireKnownName("object", object, scene_.objects);
  for (std::size_t i = 0; i < impl_->objects.size(); ++i) {
    if (impl_->objects[i].first != object) continue;
    if (along_y) *along_y = impl_->object_states[i].friction_y;
    return impl_->object_states[i].friction_x;
  }
  return 0;
}

int PhysicsWorld::contactEpisodes(const std::string& object) const {
  requireKnownName("object", object, scene_.objects);
  for (std::size_t i = 0; i < impl_->objects.size(); ++i) {
    if (impl_->objects[i].first == object) return impl_->object_states[i].episodes;
  }
  return 0;
}

}  // namespace xpersif::core
