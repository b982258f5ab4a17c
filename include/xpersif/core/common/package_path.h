/**
 * @file package_path.h
 * @brief Files named by `package://NAME/PATH`, as URDFs and launch files name them, found without ROS.
 *
 * A world whose robot is `urdf: package://xpersif/urdf/khepera.urdf` loads from any directory it is copied to, where a
 * relative path would break (`xpersif generate-world` writes worlds this way).
 */
#pragma once

#include <string>

namespace xpersif::core {

/// Whether @p path is a `package://` URI.
bool isPackageUri(const std::string& path);

/// The environment's ROS_PACKAGE_PATH ("" when unset).
std::string rosPackagePath();

/// The file `package://NAME/PATH` names: PATH inside the first directory found on @p ros_package_path (entries
/// separated by ':') whose package.xml names NAME. As rospack looks: an entry is the package itself or holds it at any
/// depth, and nothing below a package is searched. Throws std::invalid_argument with a sentence when the URI has no
/// NAME or PATH, or no package NAME is found. The file itself is not checked (its reader says if it is missing).
std::string resolvePackageUri(const std::string& uri, const std::string& ros_package_path);

/// The file a world (or any file in @p base_dir) names as @p named: a package:// URI resolved on ROS_PACKAGE_PATH, an
/// absolute path as it is, else @p base_dir/@p named. Throws std::invalid_argument as resolvePackageUri does.
std::string resolveNamedFile(const std::string& named, const std::string& base_dir);

}  // namespace xpersif::core
