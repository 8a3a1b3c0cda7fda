// Reads two images, detects L-FAST features with lfast through OpenCV's
// cv::Feature2D interface, matches them with cv::BFMatcher (Hamming,
// cross-checked) and draws the matches:
//
//   lfast_match IMAGE1 IMAGE2 OUT.png
#include <lfast/lfast_opencv.hpp>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <iostream>

int main(int argc, char** argv) {
    if (argc != 4) {
        std::cerr << "usage: " << argv[0] << " IMAGE1 IMAGE2 OUT.png" << std::endl;
        return 2;
    }
    cv::Mat a = cv::imread(argv[1]), b = cv::imread(argv[2]);
    if (a.empty() || b.empty()) {
        std::cerr << "cannot read " << (a.empty() ? argv[1] : argv[2]) << std::endl;
        return 1;
    }
    try {
        cv::Ptr<cv::Feature2D> lfast = lfast::LFast::create(2000);  // at most 2000 keypoints an image
        std::vector<cv::KeyPoint> ka, kb;
        cv::Mat da, db;
        lfast->detectAndCompute(a, cv::noArray(), ka, da);
        lfast->detectAndCompute(b, cv::noArray(), kb, db);

        std::vector<cv::DMatch> matches;
        cv::BFMatcher(lfast->defaultNorm(), true).match(da, db, matches);
        std::sort(matches.begin(), matches.end());
        matches.resize(std::min<size_t>(matches.size(), 200));  // the 200 closest

        cv::Mat out;
        cv::drawMatches(a, ka, b, kb, matches, out);
        if (!cv::imwrite(argv[3], out)) {
            std::cerr << "cannot write " << argv[3] << std::endl;
            return 1;
        }
        std::cout << ka.size() << " and " << kb.size() << " keypoints, " << matches.size() << " matches drawn to "
                  << argv[3] << std::endl;
    } catch (const lfast::Error& e) {
        std::cerr << "lfast: " << e.what() << std::endl;
        return 1;
    }
    return 0;
}
