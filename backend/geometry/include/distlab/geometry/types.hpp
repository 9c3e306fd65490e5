#pragma once
// Common linear-algebra aliases used by every numerics module.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace distlab {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using MatX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using VecX = Eigen::VectorXd;

}  // namespace distlab
