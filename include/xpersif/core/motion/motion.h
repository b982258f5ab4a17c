/**
 * @file motion.h
 * @brief The motion core behind RELOCATION and MANIPULATION, ROS-free and physics-free: controllers
 *        that turn a measured planar pose into a velocity command, a grid path planner around the arena's
 *        walls and the objects, and a push planner + controller for pushing an object (a box on one of its
 *        faces, or a cylinder or sphere along a side's axis).
 *
 * Everything works on a planar pose (x, y, yaw in the world frame, metres and radians), whatever measured
 * it (wheel odometry, the overhead camera). A caller runs a controller at a fixed control period:
 * `update(pose, dt)` returns the velocity to send to the robot, plus feedback. Controllers never sleep,
 * never talk to the simulator, and are deterministic (same inputs, same outputs).
 *
 * Bad goals and settings throw ValidationError with one sentence (controllers' setGoal/start, limits);
 * plans that cannot be made (unreachable goal, a push into a wall) are results with a reason sentence,
 * because they are ordinary outcomes that become rejected goals.
 *
 * Conventions: the robot is a disc of radius `robot_radius` that drives along its +x axis (yaw); an
 * Obstacle is an object's footprint (footprint.h: a rectangle or a disc) centred at (x, y) and rotated by
 * yaw; the arena is size_x by size_y (inner extents) centred on the world origin.
 */
#pragma once

// The motion core in three parts: shared types and controllers, path planning, pushing.
#include "xpersif/core/motion/motion_control.h"
#include "xpersif/core/motion/path_planner.h"
#include "xpersif/core/motion/push_motion.h"
