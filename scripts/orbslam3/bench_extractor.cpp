// ORB-SLAM3's own ORBextractor against lfast::ORBextractor on the same frames,
// called as Frame.cc calls them (scale 1.2, 8 levels, FAST thresholds 20/7,
// lapping area {0, 1000}): time per frame, keypoints returned and their
// spread over the levels. Built by build.sh (PREFIX/bin/bench_extractor).
//
//   bench_extractor [--repeats R] [--nfeatures N[,N...]] [--only orbslam3|lfast] FRAME...
//
// It compiles ORB-SLAM3's src/ORBextractor.cc (GPLv3) into this program;
// this file is under lfast's licence (MIT OR Apache-2.0), the program built
// from it under the GPLv3.
#include <ORBextractor.h>            // ORB-SLAM3's, namespace ORB_SLAM3
#include <lfast/orbextractor.hpp>    // lfast's drop-in, namespace lfast

#include <opencv2/imgcodecs.hpp>

#include <time.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

namespace {

/// CPU time of the whole process (every thread), in milliseconds.
double cpu_ms() {
    timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

struct Result {
    std::vector<double> ms;            // per pass: mean time per frame
    std::vector<double> cpu;           // per pass: mean CPU time per frame (all threads)
    std::vector<size_t> counts;        // keypoints per frame (last pass)
    std::vector<size_t> per_level;     // summed over the frames
};

template <class Extractor>
Result run(Extractor& ex, const std::vector<cv::Mat>& frames, int repeats, int nlevels) {
    Result r;
    r.per_level.assign(nlevels, 0);
    std::vector<int> lapping = {0, 1000};
    std::vector<cv::KeyPoint> kps;
    cv::Mat desc;
    for (int pass = 0; pass <= repeats; ++pass) {  // pass 0: warm-up, not timed
        auto t0 = std::chrono::steady_clock::now();
        double c0 = cpu_ms();
        for (size_t i = 0; i < frames.size(); ++i) {
            ex(frames[i], cv::Mat(), kps, desc, lapping);
            if (pass == repeats) {
                r.counts.push_back(kps.size());
                for (const auto& k : kps)
                    if (k.octave >= 0 && k.octave < nlevels) r.per_level[k.octave]++;
            }
        }
        auto t1 = std::chrono::steady_clock::now();
        double c1 = cpu_ms();
        if (pass > 0) {
            r.ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count() / frames.size());
            r.cpu.push_back((c1 - c0) / frames.size());
        }
    }
    return r;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void print(const char* name, int nfeatures, const Result& r, size_t frames) {
    std::vector<double> c(r.counts.begin(), r.counts.end());
    double mn = *std::min_element(r.ms.begin(), r.ms.end());
    size_t lo = *std::min_element(r.counts.begin(), r.counts.end());
    size_t hi = *std::max_element(r.counts.begin(), r.counts.end());
    double cpu_mn = *std::min_element(r.cpu.begin(), r.cpu.end());
    std::printf("{\"extractor\": \"%s\", \"nfeatures\": %d, \"frames\": %zu, \"median_ms\": %.3f, \"min_ms\": %.3f, "
                "\"cpu_median_ms\": %.3f, \"cpu_min_ms\": %.3f, "
                "\"keypoints_median\": %.1f, \"keypoints_min\": %zu, \"keypoints_max\": %zu, \"per_level\": [",
                name, nfeatures, frames, median(r.ms), mn, median(r.cpu), cpu_mn, median(c), lo, hi);
    for (size_t l = 0; l < r.per_level.size(); ++l)
        std::printf("%s%.1f", l ? ", " : "", static_cast<double>(r.per_level[l]) / frames);
    std::printf("]}\n");
}

[[noreturn]] void usage() {
    std::fprintf(stderr, "usage: bench_extractor [--repeats R] [--nfeatures N[,N...]] [--only orbslam3|lfast] FRAME...\n");
    std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
    int repeats = 5;
    std::vector<int> nfeatures = {2000};
    std::string only;
    std::vector<std::string> paths;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--repeats" && i + 1 < argc) {
            repeats = std::atoi(argv[++i]);
        } else if (a == "--nfeatures" && i + 1 < argc) {
            nfeatures.clear();
            std::stringstream ss(argv[++i]);
            for (std::string t; std::getline(ss, t, ',');) nfeatures.push_back(std::atoi(t.c_str()));
        } else if (a == "--only" && i + 1 < argc) {
            only = argv[++i];
        } else if (!a.empty() && a[0] == '-') {
            usage();
        } else {
            paths.push_back(a);
        }
    }
    if (paths.empty() || repeats < 1 || nfeatures.empty()) usage();
    std::vector<cv::Mat> frames;
    for (const auto& p : paths) {
        cv::Mat m = cv::imread(p, cv::IMREAD_GRAYSCALE);
        if (m.empty()) {
            std::fprintf(stderr, "cannot read %s\n", p.c_str());
            return 1;
        }
        frames.push_back(m);
    }
    const float scale = 1.2f;
    const int nlevels = 8, ini_th = 20, min_th = 7;
    for (int n : nfeatures) {
        if (only.empty() || only == "orbslam3") {
            ORB_SLAM3::ORBextractor ex(n, scale, nlevels, ini_th, min_th);
            print("orbslam3", n, run(ex, frames, repeats, nlevels), frames.size());
        }
        if (only.empty() || only == "lfast") {
            lfast::ORBextractor ex(n, scale, nlevels, ini_th, min_th);
            print("lfast", n, run(ex, frames, repeats, nlevels), frames.size());
        }
    }
    return 0;
}
