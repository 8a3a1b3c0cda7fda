// train_vocabulary: a DBoW2 vocabulary for ORB-SLAM3 (text format, as
// Vocabulary/ORBvoc.txt) from cv::ORB::create(NFEATURES) descriptors of
// the images listed in a file, with ORB-SLAM3's bundled DBoW2
// (TemplatedVocabulary<FORB::TDescriptor, FORB>, TF-IDF, L1 norm).
//
//   train_vocabulary IMAGE_LIST OUT.txt K L [NFEATURES=1000]
//
// k-means++ seeding uses DUtils' rand(), seeded with 0 here: the same images
// give the same vocabulary. Part of lfast's scripts/orbslam3 (build.sh);
// linked with DBoW2 (BSD) from ORB-SLAM3's tree.
// SPDX-License-Identifier: MIT OR Apache-2.0

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "Thirdparty/DBoW2/DBoW2/FORB.h"
#include "Thirdparty/DBoW2/DBoW2/TemplatedVocabulary.h"
#include "Thirdparty/DBoW2/DUtils/Random.h"

typedef DBoW2::TemplatedVocabulary<DBoW2::FORB::TDescriptor, DBoW2::FORB> ORBVocabulary;

static bool parse_int(const char* s, int lo, int hi, int& out) {
    char* end = nullptr;
    long v = std::strtol(s, &end, 10);
    if (end == s || *end != '\0' || v < lo || v > hi) return false;
    out = static_cast<int>(v);
    return true;
}

int main(int argc, char** argv) {
    if (argc < 5 || argc > 6) {
        std::cerr << "usage: train_vocabulary IMAGE_LIST OUT.txt K L [NFEATURES=1000]\n";
        return 2;
    }
    int k = 0, levels = 0, nfeatures = 1000;
    if (!parse_int(argv[3], 2, 64, k)) {
        std::cerr << "train_vocabulary: K must be an integer in 2..64, not '" << argv[3] << "'\n";
        return 2;
    }
    if (!parse_int(argv[4], 1, 8, levels)) {
        std::cerr << "train_vocabulary: L must be an integer in 1..8, not '" << argv[4] << "'\n";
        return 2;
    }
    if (argc == 6 && !parse_int(argv[5], 1, 100000, nfeatures)) {
        std::cerr << "train_vocabulary: NFEATURES must be a positive integer, not '" << argv[5] << "'\n";
        return 2;
    }
    std::ifstream list(argv[1]);
    if (!list) {
        std::cerr << "train_vocabulary: cannot read the image list " << argv[1] << "\n";
        return 1;
    }
    std::vector<std::string> paths;
    for (std::string line; std::getline(list, line);)
        if (!line.empty()) paths.push_back(line);
    if (paths.empty()) {
        std::cerr << "train_vocabulary: " << argv[1] << " lists no images\n";
        return 1;
    }

    cv::Ptr<cv::ORB> orb = cv::ORB::create(nfeatures);
    std::vector<std::vector<cv::Mat>> features;
    size_t total = 0;
    for (const std::string& path : paths) {
        cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
        if (image.empty()) {
            std::cerr << "train_vocabulary: cannot read image " << path << "\n";
            return 1;
        }
        std::vector<cv::KeyPoint> keypoints;
        cv::Mat descriptors;
        orb->detectAndCompute(image, cv::noArray(), keypoints, descriptors);
        std::vector<cv::Mat> rows;
        rows.reserve(descriptors.rows);
        for (int i = 0; i < descriptors.rows; ++i) rows.push_back(descriptors.row(i).clone());
        total += rows.size();
        features.push_back(std::move(rows));
    }

    DUtils::Random::SeedRandOnce(0);
    ORBVocabulary voc(k, levels, DBoW2::TF_IDF, DBoW2::L1_NORM);
    voc.create(features);
    voc.saveToTextFile(argv[2]);
    std::ifstream saved(argv[2], std::ios::ate);
    if (!saved || saved.tellg() <= 0) {
        std::cerr << "train_vocabulary: cannot write " << argv[2] << "\n";
        return 1;
    }
    std::printf("%zu images, %zu descriptors (cv::ORB::create(%d)), k=%d L=%d: %u words -> %s\n", paths.size(),
                total, nfeatures, k, levels, voc.size(), argv[2]);
    return 0;
}
