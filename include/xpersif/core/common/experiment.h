/**
 * @file experiment.h
 * @brief The plain data of the cognitive loop, shared by KNOWLEDGEBASE, MACHINELEARNING, MOTIVATION,
 *        DESIGNOFEXPERIMENTS and the PLANNER: a push experiment, the feature vectors seen before and after
 *        it, its outcome, a prediction of that outcome, and a notion (a learned symbolic fact).
 *
 * Conventions (metres, radians, right-handed, z up):
 *  - An EXPERIMENT is one push. `side` is the face of the object the robot pushes on, in the object's own
 *    frame: "-x", "+x", "-y" or "+y". The robot pushes along the face's inward normal: on "-x" it pushes
 *    towards +x of the object, on "+y" towards -y, and so on. A round object (upright cylinder, sphere) has no
 *    faces: its frame is the world's (its yaw cannot be seen) and the side names the push direction.
 *  - The PUSH FRAME has its x axis along that push direction and its y axis 90 degrees to the left of it,
 *    both fixed to the object's pose BEFORE the push.
 *  - `offset` is where the contact point lies across the push, measured from the face centre along the push
 *    frame's y axis (positive = left of the centre, looking along the push), within the object's limit
 *    (maxPushOffset, footprint.h).
 *  - `distance` is how far the robot drives after contact, within the set-up's limits (setup.h).
 *  - The OUTCOME is the object's motion in the push frame: dx along the push, dy to its left, dyaw the change
 *    of heading wrapped to (-pi, pi]. computeOutcome() derives it from the before and after poses.
 */
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "xpersif/core/common/pose2d.h"

namespace xpersif::core {

/// The four faces a cube can be pushed on, in the cube's frame.
const std::vector<std::string>& pushSides();

/// m: a bound on |offset| and distance that no real push reaches, whatever the set-up. Each object's own
/// limits come from its footprint and the arena (SetupCatalogue::checkExperiment, setup.h).
constexpr double kMaxPushExtent = 10.0;
constexpr std::size_t kMaxObjectsPerFeatureVector = 64;
constexpr std::size_t kMaxExtraFeatures = 32;  ///< per object
constexpr std::size_t kMaxNameLength = 128;

/// One push experiment's inputs.
struct Experiment {
  std::string object;     ///< the pushed object's name, e.g. "red_cube"
  std::string side;       ///< "-x", "+x", "-y" or "+y" (see the file comment)
  double offset = 0.0;    ///< m, lateral contact offset from the face centre, left positive
  double distance = 0.0;  ///< m, drive after contact
};

/// One object as a feature extractor sees it: its pose on the floor plus named extra features.
struct ObjectFeatures {
  std::string name;
  double x = 0.0, y = 0.0, yaw = 0.0;    ///< world pose (m, m, rad)
  std::map<std::string, double> extra;   ///< e.g. {"hue": 120, "size": 0.04}
};

/// Everything seen at one instant.
struct FeatureVector {
  double stamp = 0.0;  ///< s (simulated time)
  std::vector<ObjectFeatures> objects;

  /// The object named @p name, or nullptr.
  const ObjectFeatures* find(const std::string& name) const;
};

/// The object's motion in the push frame.
struct Outcome {
  double dx = 0.0;    ///< m along the push
  double dy = 0.0;    ///< m to the left of the push
  double dyaw = 0.0;  ///< rad, in (-pi, pi]
};

/// A predicted outcome with one standard deviation per component.
struct Prediction {
  Outcome mean;
  Outcome std;
};

/// A learned symbolic fact, e.g. {"blue_cube", "does_not_move_when_pushed", 0.01, 0.95, 12, "..."}.
struct Notion {
  std::string subject;     ///< usually an object name
  std::string predicate;   ///< snake_case, e.g. "moves_when_pushed"
  double value = 0.0;      ///< the predicate's measure (see the predicate), e.g. mean displacement ratio
  double confidence = 0.0; ///< in [0, 1]
  int support = 0;         ///< how many experiments back it
  std::string text;        ///< one English sentence
};

/// Heading of the push direction in the object's frame: "-x" -> 0, "+x" -> pi, "-y" -> pi/2, "+y" -> -pi/2.
/// Throws ValidationError for an unknown side.
double pushAngleInObject(const std::string& side);

/// The outcome of a push on @p side, from the object's poses before and after. Throws ValidationError for
/// an unknown side or non-finite poses.
Outcome computeOutcome(const ObjectFeatures& before, const ObjectFeatures& after, const std::string& side);

/// Field-named sentence ("" when fine): non-empty object name of at most kMaxNameLength characters, known
/// side, finite offset within +-kMaxPushExtent, finite distance in (0, kMaxPushExtent]. The object's own
/// limits are SetupCatalogue::checkExperiment's.
std::string checkExperiment(const std::string& field, const Experiment& experiment);
std::string checkOutcome(const std::string& field, const Outcome& outcome);
/// Finite numbers, non-empty unique object names, sizes within the caps above.
std::string checkFeatureVector(const std::string& field, const FeatureVector& features);
void requireExperiment(const std::string& field, const Experiment& experiment);
void requireOutcome(const std::string& field, const Outcome& outcome);
void requireFeatureVector(const std::string& field, const FeatureVector& features);

/// JSON text of a feature vector:
/// {"stamp":1.5,"objects":[{"name":"red_cube","x":0.1,"y":0,"yaw":0,"extra":{"hue":0}}]}.
/// Numbers are written with 17 significant digits, so that parsing gives the same doubles back.
/// Throws ValidationError for non-finite numbers (JSON has no NaN).
std::string toJson(const FeatureVector& features);
/// Parse what toJson writes (any JSON whitespace, key order and escapes accepted); throws ValidationError
/// with the position and the reason for anything else.
FeatureVector featureVectorFromJson(const std::string& json);

}  // namespace xpersif::core
