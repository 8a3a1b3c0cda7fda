// C++/OpenCV test of lfast.hpp, lfast_opencv.hpp and orbextractor.hpp, run by .ci/run:
//
//   test_opencv DUMP_DIR IMAGE...
//
// Reads each image with cv::imread (unchanged: gray or BGR), detects through
// a cv::Ptr<cv::Feature2D>, and writes DUMP_DIR/<name>.features for
// capi/tests/compare_features.py to compare with `lfast detect`'s JSON. It
// checks OpenCV's use of a Feature2D (detect, compute, ROIs, masks,
// drawKeypoints, BFMatcher), the ORBextractor interface, and that bad input
// throws lfast::Error. Exit 0 when all checks pass.
#include <lfast/orbextractor.hpp>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

static int failures = 0;
#define CHECK(cond, msg)                                              \
    do {                                                              \
        if (!(cond)) {                                                \
            std::cerr << "FAIL: " << msg << " (" #cond ")" << std::endl; \
            ++failures;                                               \
        }                                                             \
    } while (0)

static unsigned bits(float f) {
    unsigned u;
    std::memcpy(&u, &f, sizeof u);
    return u;
}

static bool same(const std::vector<cv::KeyPoint>& a, const std::vector<cv::KeyPoint>& b) {
    if (a.size() != b.size()) return false;
    for (size_t i = 0; i < a.size(); ++i) {
        const cv::KeyPoint &p = a[i], &q = b[i];
        if (bits(p.pt.x) != bits(q.pt.x) || bits(p.pt.y) != bits(q.pt.y) || bits(p.size) != bits(q.size) ||
            bits(p.angle) != bits(q.angle) || bits(p.response) != bits(q.response) || p.octave != q.octave ||
            p.class_id != q.class_id)
            return false;
    }
    return true;
}

static bool same(const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && (a.empty() || cv::norm(a, b, cv::NORM_INF) == 0);
}

static void dump(const std::string& dir, const std::string& path, const std::vector<cv::KeyPoint>& kps,
                 const cv::Mat& desc) {
    std::string name = path.substr(path.find_last_of('/') + 1);
    FILE* out = std::fopen((dir + "/" + name + ".features").c_str(), "w");
    if (!out) {
        CHECK(false, "cannot write the dump of " << path);
        return;
    }
    for (size_t i = 0; i < kps.size(); ++i) {
        const cv::KeyPoint& k = kps[i];
        std::fprintf(out, "%08x %08x %08x %08x %08x %d %d ", bits(k.pt.x), bits(k.pt.y), bits(k.size), bits(k.angle),
                     bits(k.response), k.octave, k.class_id);
        for (int j = 0; j < 32; ++j) std::fprintf(out, "%02x", desc.at<uint8_t>(static_cast<int>(i), j));
        std::fprintf(out, "\n");
    }
    std::fclose(out);
}

template <class F>
static void expect_throw(F f, LfastStatus want, const std::string& needle, const std::string& what) {
    try {
        f();
        CHECK(false, what << ": no exception");
    } catch (const lfast::Error& e) {
        CHECK(e.status() == want, what << ": status " << e.status() << ", expected " << want << " (" << e.what() << ")");
        CHECK(std::string(e.what()).find(needle) != std::string::npos,
              what << ": message \"" << e.what() << "\" lacks \"" << needle << "\"");
    }
}

static void feature2d_checks(const cv::Ptr<cv::Feature2D>& f, const cv::Mat& img, const std::vector<cv::KeyPoint>& kps,
                             const cv::Mat& desc, const std::string& path) {
    CHECK(f->descriptorSize() == 32 && f->descriptorType() == CV_8U && f->defaultNorm() == cv::NORM_HAMMING,
          "Feature2D accessors");
    CHECK(desc.rows == static_cast<int>(kps.size()) && desc.cols == 32 && desc.type() == CV_8UC1,
          path << ": descriptors are N x 32 CV_8U");
    // detect, then compute, = detectAndCompute
    std::vector<cv::KeyPoint> k2;
    f->detect(img, k2);
    CHECK(same(k2, kps), path << ": detect differs");
    cv::Mat d2;
    f->compute(img, k2, d2);
    CHECK(same(k2, kps) && same(d2, desc), path << ": compute differs");
    // an ROI (rows with padding) = the image
    cv::Mat big;
    cv::copyMakeBorder(img, big, 3, 2, 5, 7, cv::BORDER_CONSTANT, cv::Scalar::all(9));
    std::vector<cv::KeyPoint> k3;
    cv::Mat d3;
    f->detectAndCompute(big(cv::Rect(5, 3, img.cols, img.rows)), cv::noArray(), k3, d3);
    CHECK(same(k3, kps) && same(d3, desc), path << ": ROI differs");
    // a mask zeroing the left half
    cv::Mat mask(img.size(), CV_8UC1, cv::Scalar(255));
    mask(cv::Rect(0, 0, img.cols / 2, img.rows)).setTo(0);
    std::vector<cv::KeyPoint> km;
    cv::Mat dm;
    f->detectAndCompute(img, mask, km, dm);
    CHECK(km.size() < kps.size() && dm.rows == static_cast<int>(km.size()), path << ": mask");
    for (const auto& k : km) CHECK(k.pt.x >= img.cols / 2, path << ": a keypoint at x " << k.pt.x << " is masked");
    // OpenCV's own consumers take the results
    cv::Mat drawn;
    cv::drawKeypoints(img, kps, drawn, cv::Scalar::all(-1), cv::DrawMatchesFlags::DRAW_RICH_KEYPOINTS);
    CHECK(drawn.size() == img.size() && drawn.type() == CV_8UC3, path << ": drawKeypoints");
    std::vector<cv::DMatch> matches;
    cv::BFMatcher(f->defaultNorm(), true).match(desc, desc, matches);
    int zero = 0;
    for (const auto& m : matches) zero += m.distance == 0;
    CHECK(!matches.empty() && zero == static_cast<int>(matches.size()), path << ": BFMatcher on itself");
    cv::Mat canvas;
    cv::drawMatches(img, kps, img, kps, matches, canvas);
    CHECK(canvas.cols == 2 * img.cols, path << ": drawMatches");
}

static void bad_input(const cv::Ptr<cv::Feature2D>& f, const cv::Mat& img) {
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    cv::Mat f32;
    img.convertTo(f32, CV_32F);
    expect_throw([&] { f->detectAndCompute(f32, cv::noArray(), k, d); }, LFAST_STATUS_INVALID_ARGUMENT, "CV_8U or CV_16U",
                 "float image");
    cv::Mat two(img.rows, img.cols, CV_8UC2, cv::Scalar::all(1));
    expect_throw([&] { f->detect(two, k); }, LFAST_STATUS_INVALID_ARGUMENT, "1, 3 (BGR) or 4 (BGRA) channels, got 2",
                 "2 channels");
    cv::Mat small_mask(img.rows / 2, img.cols, CV_8UC1, cv::Scalar(255));
    expect_throw([&] { f->detect(img, k, small_mask); }, LFAST_STATUS_INVALID_ARGUMENT, "mask is", "mask size");
    cv::Mat mask16(img.size(), CV_16UC1, cv::Scalar(255));
    expect_throw([&] { f->detect(img, k, mask16); }, LFAST_STATUS_INVALID_ARGUMENT, "CV_8UC1", "16-bit mask");
    std::vector<cv::KeyPoint> outside{cv::KeyPoint(-4.f, 3.f, 31.f)};
    expect_throw([&] { f->compute(img, outside, d); }, LFAST_STATUS_INVALID_ARGUMENT, "keypoint 0", "keypoint outside");
    lfast::Config c = lfast::default_config();
    c.support = 0;
    expect_throw([&] { lfast::LFast::create(c, lfast::Backend::Cpu); }, LFAST_STATUS_INVALID_CONFIG, "`support`",
                 "bad config");
    expect_throw([&] { lfast::LFast::create(100, 0.5); }, LFAST_STATUS_INVALID_CONFIG, "`scale_factor`", "bad scale");
    expect_throw([&] { lfast::Detector::from_toml("n_levels = 0", lfast::Backend::Cpu); }, LFAST_STATUS_INVALID_CONFIG,
                 "`n_levels`", "bad toml");
    expect_throw([&] { lfast::imread("/nonexistent/lfast.png"); }, LFAST_STATUS_IO, "nonexistent", "missing file");
    // an empty image is no keypoints, as with OpenCV's detectors
    k.assign(3, cv::KeyPoint());
    f->detectAndCompute(cv::Mat(), cv::noArray(), k, d);
    CHECK(k.empty() && d.empty(), "empty image");
}

static void orbextractor_checks(const cv::Mat& img, const std::string& path) {
    cv::Mat gray;
    if (img.channels() == 3)
        cv::cvtColor(img, gray, cv::COLOR_BGR2GRAY);
    else
        gray = img;
    lfast::ORBextractor ex(300, 1.2f, 8, 20, 7, lfast::Backend::Cpu);
    CHECK(ex.GetLevels() == 8 && ex.GetScaleFactor() == 1.2f, "ORBextractor levels");
    {
        const lfast::Config c = ex.lfast().config();
        CHECK(c.snap_radius == 0 && c.distribution && c.orientation_bins == 0 &&
                  c.descriptor == LFAST_DESCRIPTOR_KIND_OPENCV && c.n_features == 300 && c.fill_fast_ini == 20 &&
                  c.fill_fast_min == 7,
              "ORBextractor's config (docs/orbslam.md): no snap, quadtree, continuous angle, cv2 descriptor, fill");
    }
    std::vector<float> s = ex.GetScaleFactors(), is = ex.GetInverseScaleFactors(), s2 = ex.GetScaleSigmaSquares(),
                       is2 = ex.GetInverseScaleSigmaSquares();
    CHECK(s.size() == 8 && s[0] == 1.f && std::fabs(s[7] - std::pow(1.2f, 7.f)) < 1e-4f, "GetScaleFactors");
    CHECK(std::fabs(is[3] * s[3] - 1) < 1e-6f && std::fabs(s2[2] - s[2] * s[2]) < 1e-6f &&
              std::fabs(is2[2] * s2[2] - 1) < 1e-6f,
          "inverse and sigma squares");
    std::vector<cv::KeyPoint> kps;
    cv::Mat desc;
    std::vector<int> lapping{img.cols / 3, 2 * img.cols / 3};
    int mono = ex(gray, cv::Mat(), kps, desc, lapping);
    CHECK(!kps.empty() && kps.size() <= 300, path << ": ORBextractor found " << kps.size() << " keypoints");
    CHECK(desc.rows == static_cast<int>(kps.size()) && desc.cols == 32 && desc.type() == CV_8U, "ORBextractor descriptors");
    CHECK(mono >= 0 && mono <= static_cast<int>(kps.size()), "ORBextractor return");
    int levels = 0;
    for (int i = 0; i < static_cast<int>(kps.size()); ++i) {
        const cv::KeyPoint& k = kps[i];
        bool in = k.pt.x >= lapping[0] && k.pt.x <= lapping[1];
        CHECK(in == (i >= mono), path << ": keypoint " << i << " on the wrong side of the lapping area");
        CHECK(k.pt.x >= 0 && k.pt.y >= 0 && k.pt.x < img.cols && k.pt.y < img.rows, "level-0 coordinates");
        CHECK(k.octave >= 0 && k.octave < 8 && std::fabs(k.size - 31.f * s[k.octave]) < 1e-3f * k.size,
              path << ": octave " << k.octave << " size " << k.size);
        levels |= 1 << k.octave;
    }
    CHECK(levels > 1, path << ": keypoints from one level only");
    // the same keypoints and descriptors as the Feature2D with its config, reordered
    std::vector<cv::KeyPoint> k2;
    cv::Mat d2;
    ex.lfast().detectAndCompute(gray, cv::noArray(), k2, d2);
    CHECK(k2.size() == kps.size(), "ORBextractor vs LFast count");
    int found = 0;
    for (size_t i = 0; i < k2.size(); ++i)
        for (size_t j = 0; j < kps.size(); ++j)
            if (bits(k2[i].pt.x) == bits(kps[j].pt.x) && bits(k2[i].pt.y) == bits(kps[j].pt.y) &&
                k2[i].octave == kps[j].octave && same(d2.row(static_cast<int>(i)), desc.row(static_cast<int>(j)))) {
                ++found;
                break;
            }
    CHECK(found == static_cast<int>(k2.size()), path << ": ORBextractor output is not LFast's, reordered");
    CHECK(ex.mvImagePyramid.size() == 8 && ex.mvImagePyramid[0].size() == gray.size() &&
              ex.mvImagePyramid[1].cols == cvRound(gray.cols / 1.2f),
          "mvImagePyramid");
    std::vector<int> none{0, -1};
    CHECK(ex(cv::Mat(), cv::Mat(), kps, desc, none) == -1, "ORBextractor on an empty image");
}

// With REQUIRE_GPU=1 (CI, on lavapipe) the GPU backend must open and give
// the CPU's features bit for bit.
static void gpu_checks(const cv::Mat& img, const std::vector<cv::KeyPoint>& kps, const cv::Mat& desc,
                       const std::string& path) {
    const char* require = std::getenv("REQUIRE_GPU");
    if (!require || std::string(require) != "1") return;
    cv::Ptr<lfast::LFast> g = lfast::LFast::create(lfast::default_config(), lfast::Backend::Gpu);
    CHECK(g->backend() == "gpu", "the GPU backend runs on " << g->backend());
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    g->detectAndCompute(img, cv::noArray(), k, d);
    CHECK(same(k, kps) && same(d, desc), path << ": GPU features differ from the CPU's");
    std::cout << path << ": GPU (" << k.size() << " keypoints) = CPU" << std::endl;
}

int main(int argc, char** argv) {
    if (argc < 3) {
        std::cerr << "usage: " << argv[0] << " DUMP_DIR IMAGE..." << std::endl;
        return 2;
    }
    std::cout << "lfast " << lfast::version() << ", OpenCV " << CV_VERSION << std::endl;
    // as with cv::ORB: a cv::Ptr<cv::Feature2D>
    cv::Ptr<cv::Feature2D> f = lfast::LFast::create(lfast::default_config(), lfast::Backend::Cpu);
    CHECK(f->getDefaultName() == "Feature2D.LFast", "name");
    for (int i = 2; i < argc; ++i) {
        std::string path = argv[i];
        cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
        if (img.empty()) {
            CHECK(false, "cannot read " << path);
            continue;
        }
        std::vector<cv::KeyPoint> kps;
        cv::Mat desc;
        f->detectAndCompute(img, cv::noArray(), kps, desc);
        std::cout << path << ": " << img.cols << "x" << img.rows << "x" << img.channels() << ", " << kps.size()
                  << " keypoints" << std::endl;
        dump(argv[1], path, kps, desc);
        if (i == 2) {
            gpu_checks(img, kps, desc, path);
            feature2d_checks(f, img, kps, desc, path);
            bad_input(f, img);
            orbextractor_checks(img, path);
        }
    }
    if (failures) {
        std::cerr << failures << " check(s) failed" << std::endl;
        return 1;
    }
    std::cout << "all C++/OpenCV checks passed" << std::endl;
    return 0;
}
