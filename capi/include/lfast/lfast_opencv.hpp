// lfast as an OpenCV cv::Feature2D: header-only over lfast.hpp.
// SPDX-License-Identifier: MIT OR Apache-2.0
//
//   cv::Ptr<cv::Feature2D> f = lfast::LFast::create();
//   std::vector<cv::KeyPoint> kps; cv::Mat desc;
//   f->detectAndCompute(image, cv::noArray(), kps, desc);   // desc: N x 32 CV_8U
//   cv::BFMatcher(f->defaultNorm(), true).match(desc, desc2, matches);
//
// Inputs: CV_8U or CV_16U, 1 (gray), 3 (BGR) or 4 (BGRA) channels, any row
// step (ROIs included); masks CV_8UC1 of the image's size (nonzero = keep).
// Keypoints are filled as the Python package fills cv2.KeyPoint: position,
// size (31 * scale of the level), angle (degrees), response, octave, class_id -1.
#ifndef LFAST_OPENCV_HPP
#define LFAST_OPENCV_HPP

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include <string>
#include <vector>

#include "lfast.hpp"

namespace lfast {

/// A cv::Mat as an lfast image (no copy); `what` names it in errors.
inline Image image_of(const cv::Mat& m, const char* what = "image") {
    int depth = m.depth(), cn = m.channels();
    if (m.dims != 2) throw Error(LFAST_STATUS_INVALID_ARGUMENT, std::string(what) + " must be 2-D");
    if (depth != CV_8U && depth != CV_16U)
        throw Error(LFAST_STATUS_INVALID_ARGUMENT,
                    std::string(what) + " must be CV_8U or CV_16U, got depth " + std::to_string(depth));
    LfastPixelFormat f;
    bool wide = depth == CV_16U;
    switch (cn) {
        case 1: f = wide ? LFAST_PIXEL_FORMAT_GRAY16 : LFAST_PIXEL_FORMAT_GRAY8; break;
        case 3: f = wide ? LFAST_PIXEL_FORMAT_BGR16 : LFAST_PIXEL_FORMAT_BGR8; break;
        case 4: f = wide ? LFAST_PIXEL_FORMAT_BGRA16 : LFAST_PIXEL_FORMAT_BGRA8; break;
        default:
            throw Error(LFAST_STATUS_INVALID_ARGUMENT, std::string(what) + " must have 1, 3 (BGR) or 4 (BGRA) channels, got " +
                                                           std::to_string(cn));
    }
    return Image{m.data, static_cast<uint32_t>(m.cols), static_cast<uint32_t>(m.rows), m.step[0],
                 static_cast<int32_t>(f)};
}

/// An lfast keypoint as cv::KeyPoint (the same fields).
inline cv::KeyPoint to_cv(const KeyPoint& k) {
    return cv::KeyPoint(k.x, k.y, k.size, k.angle, k.response, k.octave, k.class_id);
}
inline KeyPoint from_cv(const cv::KeyPoint& k) {
    return KeyPoint{k.pt.x, k.pt.y, k.size, k.angle, k.response, k.octave, k.class_id};
}

/// Copies library-owned features into OpenCV's types; descriptors only if asked.
inline void to_cv(const Features& f, std::vector<cv::KeyPoint>& keypoints, cv::OutputArray descriptors) {
    keypoints.clear();
    keypoints.reserve(f.size());
    for (std::size_t i = 0; i < f.size(); ++i) keypoints.push_back(to_cv(f.keypoint(i)));
    if (!descriptors.needed()) return;
    if (f.empty() || !f.has_descriptors()) {
        descriptors.release();
        return;
    }
    descriptors.create(static_cast<int>(f.size()), 32, CV_8U);
    cv::Mat d = descriptors.getMat();
    cv::Mat(static_cast<int>(f.size()), 32, CV_8U, const_cast<uint8_t*>(f.descriptors())).copyTo(d);
}

/// L-FAST keypoints and rBRIEF descriptors as a cv::Feature2D.
class LFast : public cv::Feature2D {
public:
    explicit LFast(const Config& config = default_config(), Backend backend = Backend::Auto)
        : det_(config, backend) {}

    /// A detector with `config` on `backend`.
    static cv::Ptr<LFast> create(const Config& config = default_config(), Backend backend = Backend::Auto) {
        return cv::makePtr<LFast>(config, backend);
    }
    /// A detector from the config fields, ORB's first three first; every
    /// omitted argument takes its default (lfast_config_default()).
    static cv::Ptr<LFast> create(int nfeatures, double scaleFactor = default_config().scale_factor,
                                 int nlevels = static_cast<int>(default_config().n_levels),
                                 int border = static_cast<int>(default_config().border),
                                 bool distribution = default_config().distribution,
                                 int orientationBins = static_cast<int>(default_config().orientation_bins),
                                 double delta = default_config().delta,
                                 int alphaPct = static_cast<int>(default_config().alpha_pct),
                                 LfastMode mode = static_cast<LfastMode>(default_config().mode),
                                 int support = static_cast<int>(default_config().support),
                                 int straightTol = static_cast<int>(default_config().straight_tol),
                                 int nmsRadius = static_cast<int>(default_config().nms_radius),
                                 int snapRadius = static_cast<int>(default_config().snap_radius),
                                 LfastDescriptorKind descriptor = static_cast<LfastDescriptorKind>(default_config().descriptor),
                                 Backend backend = Backend::Auto,
                                 bool rejectEdges = default_config().reject_edges) {
        auto u = [](int v) { return v < 0 ? UINT32_MAX : static_cast<uint32_t>(v); };  // negative: rejected by validation
        Config c = default_config();
        c.n_features = u(nfeatures);
        c.scale_factor = scaleFactor;
        c.n_levels = u(nlevels);
        c.border = u(border);
        c.distribution = distribution;
        c.orientation_bins = u(orientationBins);
        c.delta = delta;
        c.alpha_pct = u(alphaPct);
        c.mode = static_cast<int32_t>(mode);
        c.support = u(support);
        c.straight_tol = u(straightTol);
        c.nms_radius = u(nmsRadius);
        c.snap_radius = u(snapRadius);
        c.descriptor = static_cast<int32_t>(descriptor);
        c.reject_edges = rejectEdges;
        return create(c, backend);
    }

    /// Detects (and describes, when `descriptors` is wanted), or describes the
    /// given keypoints when `useProvidedKeypoints`. An empty image gives no
    /// keypoints, as OpenCV's detectors do; other bad input throws lfast::Error.
    void detectAndCompute(cv::InputArray image, cv::InputArray mask, std::vector<cv::KeyPoint>& keypoints,
                          cv::OutputArray descriptors, bool useProvidedKeypoints = false) override {
        cv::Mat img = image.getMat();
        if (img.empty()) {
            keypoints.clear();
            if (descriptors.needed()) descriptors.release();
            return;
        }
        Image in = image_of(img);
        if (useProvidedKeypoints) {
            std::vector<KeyPoint> given;
            given.reserve(keypoints.size());
            for (const auto& k : keypoints) given.push_back(from_cv(k));
            Features f = det_.compute(in, given);
            std::vector<cv::KeyPoint> same;
            to_cv(f, same, descriptors);
            return;
        }
        cv::Mat m = mask.getMat();
        Image min{};
        if (!m.empty()) {
            if (m.type() != CV_8UC1) throw Error(LFAST_STATUS_INVALID_ARGUMENT, "mask must be CV_8UC1");
            min = image_of(m, "mask");
        }
        const Image* pm = m.empty() ? nullptr : &min;
        Features f = descriptors.needed() ? det_.detect_and_compute(in, pm) : det_.detect(in, pm);
        to_cv(f, keypoints, descriptors);
    }

    int descriptorSize() const override { return 32; }
    int descriptorType() const override { return CV_8U; }
    int defaultNorm() const override { return cv::NORM_HAMMING; }
    bool empty() const override { return false; }
    cv::String getDefaultName() const override { return "Feature2D.LFast"; }

    /// The configuration and the backend in use ("gpu" or "cpu").
    Config config() const { return det_.config(); }
    std::string backend() const { return det_.backend(); }
    /// The underlying detector (edges, the raw C handle).
    const Detector& detector() const noexcept { return det_; }

private:
    Detector det_;
};

}  // namespace lfast

#endif  // LFAST_OPENCV_HPP
