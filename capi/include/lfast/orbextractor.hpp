// lfast::ORBextractor: L-FAST with ORB-SLAM3's ORBextractor interface, so
// that ORB-SLAM3 runs on lfast features by changing a few lines (docs/orbslam.md).
// SPDX-License-Identifier: MIT OR Apache-2.0
#ifndef LFAST_ORBEXTRACTOR_HPP
#define LFAST_ORBEXTRACTOR_HPP

#include <opencv2/imgproc.hpp>

#include <vector>

#include "lfast_opencv.hpp"

namespace lfast {

/// ORB-SLAM3's ORBextractor over L-FAST. Keypoints are in level-0 (input)
/// coordinates with `octave` set to their pyramid level and `size` 31 times
/// its scale, as ORB-SLAM3 expects; they are spread over the image by
/// ORB-SLAM's quadtree (`distribution`), and oriented continuously
/// (`orientation_bins = 0`). Their descriptors are cv2 ORB's bit for bit
/// (`descriptor = "opencv"`), as ORBvoc.txt was trained on: so the extractor
/// describes on the CPU (Backend::Gpu throws on it, Backend::Auto describes
/// on the CPU; docs/algorithm.md).
///
/// `iniThFAST` and `minThFAST` play the part they play in ORB-SLAM3's own
/// extractor, for the corners L-FAST does not find: L-FAST's thresholds come
/// from its adaptive Canny stage (SPEC 1-5), so a smooth or dark level can
/// hold fewer L-FAST corners than its share of `nfeatures`; such a level is
/// topped up with FAST-9 corners found cell by cell at `iniThFAST`, retried
/// at `minThFAST` in a cell with none, as ORB-SLAM3 finds its own
/// (`fill_fast_ini`, `fill_fast_min`; `class_id` 1). Every L-FAST corner of a
/// level is kept before any of them, so about `nfeatures` keypoints come
/// back where the image has that much texture. `iniThFAST <= 0` turns the
/// fill off; `minThFAST` is clamped into `1..=iniThFAST`.
/// `mvImagePyramid` is built as ORB-SLAM3 builds it (bilinear
/// cv::resize of the previous level to `cvRound(size / scale)`), for the
/// stereo matcher that reads it; detection uses lfast's own pyramid (SPEC 10).
class ORBextractor {
public:
    enum { HARRIS_SCORE = 0, FAST_SCORE = 1 };

    ORBextractor(int nfeatures, float scaleFactor, int nlevels, int iniThFAST, int minThFAST,
                 Backend backend = Backend::Auto)
        : nfeatures_(nfeatures), scaleFactor_(scaleFactor), nlevels_(nlevels), iniThFAST_(iniThFAST),
          minThFAST_(minThFAST), det_(config_for(nfeatures, scaleFactor, nlevels, iniThFAST, minThFAST), backend) {
        mvScaleFactor.resize(nlevels);
        mvLevelSigma2.resize(nlevels);
        mvScaleFactor[0] = 1.0f;
        mvLevelSigma2[0] = 1.0f;
        for (int i = 1; i < nlevels; i++) {
            mvScaleFactor[i] = mvScaleFactor[i - 1] * scaleFactor;
            mvLevelSigma2[i] = mvScaleFactor[i] * mvScaleFactor[i];
        }
        mvInvScaleFactor.resize(nlevels);
        mvInvLevelSigma2.resize(nlevels);
        for (int i = 0; i < nlevels; i++) {
            mvInvScaleFactor[i] = 1.0f / mvScaleFactor[i];
            mvInvLevelSigma2[i] = 1.0f / mvLevelSigma2[i];
        }
        mvImagePyramid.resize(nlevels);
    }
    ~ORBextractor() = default;

    /// Detects and describes `image` (8 or 16-bit gray, BGR or BGRA) where
    /// `mask` is nonzero. As ORB-SLAM3's: keypoints with x outside
    /// [vLappingArea[0], vLappingArea[1]] come first, those inside fill the
    /// vector from its end; the return value is the number outside (-1 for an
    /// empty image). Descriptors: N x 32 CV_8U, row i of keypoint i.
    int operator()(cv::InputArray image, cv::InputArray mask, std::vector<cv::KeyPoint>& keypoints,
                   cv::OutputArray descriptors, std::vector<int>& vLappingArea) {
        if (image.empty()) return -1;
        cv::Mat img = image.getMat();
        ComputePyramid(img);
        std::vector<cv::KeyPoint> kps;
        cv::Mat desc;
        det_.detectAndCompute(img, mask, kps, desc);
        const int n = static_cast<int>(kps.size());
        keypoints.assign(n, cv::KeyPoint());
        if (n == 0) {
            descriptors.release();
            return 0;
        }
        descriptors.create(n, 32, CV_8U);
        cv::Mat out = descriptors.getMat();
        const float lo = vLappingArea.size() > 0 ? static_cast<float>(vLappingArea[0]) : 0.0f;
        const float hi = vLappingArea.size() > 1 ? static_cast<float>(vLappingArea[1]) : -1.0f;
        int mono = 0, stereo = n - 1;
        for (int i = 0; i < n; ++i) {
            int at = (kps[i].pt.x >= lo && kps[i].pt.x <= hi) ? stereo-- : mono++;
            keypoints[at] = kps[i];
            desc.row(i).copyTo(out.row(at));
        }
        return mono;
    }

    int GetLevels() { return nlevels_; }
    float GetScaleFactor() { return scaleFactor_; }
    std::vector<float> GetScaleFactors() { return mvScaleFactor; }
    std::vector<float> GetInverseScaleFactors() { return mvInvScaleFactor; }
    std::vector<float> GetScaleSigmaSquares() { return mvLevelSigma2; }
    std::vector<float> GetInverseScaleSigmaSquares() { return mvInvLevelSigma2; }

    /// The frame's pyramid, level 0 the input as 8-bit gray.
    std::vector<cv::Mat> mvImagePyramid;

    /// The lfast detector behind it (config, backend).
    LFast& lfast() noexcept { return det_; }
    int GetFeatures() const noexcept { return nfeatures_; }
    int GetIniThFAST() const noexcept { return iniThFAST_; }
    int GetMinThFAST() const noexcept { return minThFAST_; }

protected:
    static Config config_for(int nfeatures, float scaleFactor, int nlevels, int iniThFAST, int minThFAST) {
        Config c = default_config();
        c.n_features = nfeatures < 0 ? UINT32_MAX : static_cast<uint32_t>(nfeatures);
        c.scale_factor = scaleFactor;
        c.n_levels = nlevels < 0 ? UINT32_MAX : static_cast<uint32_t>(nlevels);
        c.distribution = true;
        c.orientation_bins = 0;
        c.descriptor = LFAST_DESCRIPTOR_KIND_OPENCV;
        // Corners stay on their L-FAST pixel: the sub-pixel snap to the Harris
        // maximum helps lfast's own matching but costs ORB-SLAM3's stereo and
        // monocular tracking (docs/orbslam.md, "Results").
        c.snap_radius = 0;
        if (iniThFAST > 0 && c.n_features > 0) {
            // above 255 is refused by the validation, with the field's name
            c.fill_fast_ini = static_cast<uint32_t>(iniThFAST);
            c.fill_fast_min = static_cast<uint32_t>(minThFAST < 1 ? 1 : (minThFAST > iniThFAST ? iniThFAST : minThFAST));
        }
        return c;
    }

    /// 8-bit gray as SPEC 0 makes it: 16-bit samples `>> 8`, then OpenCV's
    /// BGR(A) to gray, which is SPEC 0's integer luma on 8-bit input.
    static cv::Mat gray_of(const cv::Mat& image) {
        if (image.type() == CV_8UC1) return image;
        cv::Mat eight = image;
        if (image.depth() == CV_16U) {
            eight.create(image.rows, image.cols, CV_MAKETYPE(CV_8U, image.channels()));
            const int n = image.cols * image.channels();
            for (int y = 0; y < image.rows; ++y) {
                const uint16_t* s = image.ptr<uint16_t>(y);
                uint8_t* d = eight.ptr<uint8_t>(y);
                for (int i = 0; i < n; ++i) d[i] = static_cast<uint8_t>(s[i] >> 8);
            }
        }
        if (eight.channels() == 1) return eight;
        cv::Mat gray;
        cv::cvtColor(eight, gray, eight.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
        return gray;
    }

    void ComputePyramid(const cv::Mat& image) {
        cv::Mat gray = gray_of(image);
        for (int level = 0; level < nlevels_; ++level) {
            if (level == 0) {
                mvImagePyramid[0] = gray;
            } else {
                float inv = mvInvScaleFactor[level];
                cv::Size sz(cvRound(static_cast<float>(gray.cols) * inv), cvRound(static_cast<float>(gray.rows) * inv));
                cv::resize(mvImagePyramid[level - 1], mvImagePyramid[level], sz, 0, 0, cv::INTER_LINEAR);
            }
        }
    }

    std::vector<float> mvScaleFactor;
    std::vector<float> mvInvScaleFactor;
    std::vector<float> mvLevelSigma2;
    std::vector<float> mvInvLevelSigma2;

    int nfeatures_;
    float scaleFactor_;
    int nlevels_;
    int iniThFAST_;
    int minThFAST_;
    LFast det_;
};

}  // namespace lfast

#endif  // LFAST_ORBEXTRACTOR_HPP
