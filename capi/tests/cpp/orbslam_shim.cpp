// capi/orbslam/ORBextractor.h as ORB-SLAM3 uses it, compiled as C++11 (ORB-SLAM3's
// -std=c++11): Frame.h's forward declaration first, then the header, then the
// calls Tracking.cc and Frame.cc make. Run by .ci/run:
//
//   orbslam_shim IMAGE
#include <opencv2/imgcodecs.hpp>

#include <iostream>
#include <vector>

namespace ORB_SLAM3 {
class ORBextractor;  // as in ORB-SLAM3's include/Frame.h
}

#include "ORBextractor.h"

int main(int argc, char** argv) {
    if (argc != 2) {
        std::cerr << "usage: " << argv[0] << " IMAGE" << std::endl;
        return 2;
    }
    cv::Mat im = cv::imread(argv[1], cv::IMREAD_GRAYSCALE);
    if (im.empty()) {
        std::cerr << "cannot read " << argv[1] << std::endl;
        return 2;
    }
    // Tracking.cc: new ORBextractor(nFeatures, fScaleFactor, nLevels, fIniThFAST, fMinThFAST)
    ORB_SLAM3::ORBextractor* extractor = new ORB_SLAM3::ORBextractor(1000, 1.2f, 8, 20, 7);
    // Frame.cc (monocular): ExtractORB(0, imGray, 0, 1000)
    std::vector<cv::KeyPoint> keys;
    cv::Mat descriptors;
    std::vector<int> lapping = {0, 1000};
    int mono = (*extractor)(im, cv::Mat(), keys, descriptors, lapping);
    bool ok = !keys.empty() && keys.size() <= 1000 && descriptors.rows == static_cast<int>(keys.size()) &&
              mono >= 0 && mono <= static_cast<int>(keys.size()) && extractor->GetLevels() == 8 &&
              extractor->GetScaleFactors().size() == 8 && extractor->GetInverseScaleSigmaSquares().size() == 8 &&
              extractor->mvImagePyramid.size() == 8 && extractor->mvImagePyramid[0].size() == im.size();
    for (size_t i = 0; i < keys.size(); ++i) {
        bool inside = keys[i].pt.x >= lapping[0] && keys[i].pt.x <= lapping[1];
        ok = ok && inside == (static_cast<int>(i) >= mono);
    }
    std::cout << keys.size() << " keypoints, " << mono << " outside the lapping area" << std::endl;
    delete extractor;
    if (!ok) {
        std::cerr << "FAIL: ORB-SLAM3's use of ORBextractor" << std::endl;
        return 1;
    }
    std::cout << "ORB-SLAM3 drop-in checks passed" << std::endl;
    return 0;
}
