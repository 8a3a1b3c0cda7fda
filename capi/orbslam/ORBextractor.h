// ORB-SLAM3's include/ORBextractor.h replaced by lfast (docs/orbslam.md):
// copy this file over it, drop src/ORBextractor.cc from ORB-SLAM3's
// CMakeLists.txt and link lfast::lfast. ORB-SLAM3 declares
// `class ORBextractor;` in its namespace (Frame.h), so this is a class of
// that name deriving from lfast's, with its constructors; it compiles as C++11.
// SPDX-License-Identifier: MIT OR Apache-2.0
#ifndef ORBEXTRACTOR_H
#define ORBEXTRACTOR_H

#include <lfast/orbextractor.hpp>

namespace ORB_SLAM3 {

class ORBextractor : public lfast::ORBextractor {
public:
    using lfast::ORBextractor::ORBextractor;
};

}  // namespace ORB_SLAM3

#endif  // ORBEXTRACTOR_H
