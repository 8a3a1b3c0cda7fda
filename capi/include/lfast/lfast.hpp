// lfast C++17 wrapper over the C ABI (lfast.h): header-only, RAII, throws
// lfast::Error on failure. SPDX-License-Identifier: MIT OR Apache-2.0
//
//   lfast::Detector det;                                  // default config, auto backend
//   auto f = det.detect_and_compute(lfast::gray8(pixels, w, h, stride));
//   for (std::size_t i = 0; i < f.size(); ++i) use(f.keypoint(i), f.descriptor(i));
//
// Thread safety: one Detector may be used from several threads at once.
#ifndef LFAST_HPP
#define LFAST_HPP

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "lfast.h"

namespace lfast {

/// A failed call: the C status and the library's message.
class Error : public std::runtime_error {
public:
    Error(LfastStatus status, const std::string& message) : std::runtime_error(message), status_(status) {}
    /// The C status (never LFAST_STATUS_OK).
    LfastStatus status() const noexcept { return status_; }

private:
    LfastStatus status_;
};

/// Throws lfast::Error with the thread's last error unless `s` is OK.
inline void check(LfastStatus s) {
    if (s != LFAST_STATUS_OK) throw Error(s, lfast_last_error());
}

/// Every detector parameter (see lfast.h); default_config() gives the defaults.
using Config = LfastConfig;
/// A keypoint with cv::KeyPoint's fields.
using KeyPoint = LfastKeyPoint;
/// A borrowed strided image (see lfast.h).
using Image = LfastImage;

/// Where detection runs.
enum class Backend : int32_t { Auto = LFAST_BACKEND_AUTO, Gpu = LFAST_BACKEND_GPU, Cpu = LFAST_BACKEND_CPU };

inline Config default_config() { return lfast_config_default(); }
inline std::string version() { return lfast_version(); }

/// An image over caller memory; `stride` in bytes (0 = rows are packed).
inline Image image(const void* data, uint32_t width, uint32_t height, std::size_t stride, LfastPixelFormat format) {
    static const std::size_t bytes_per_pixel[] = {1, 2, 3, 6, 4, 8};
    int f = static_cast<int>(format);
    std::size_t packed = (f >= 0 && f < 6) ? width * bytes_per_pixel[f] : 0;
    return Image{data, width, height, stride ? stride : packed, static_cast<int32_t>(format)};
}
/// An 8-bit gray image.
inline Image gray8(const uint8_t* data, uint32_t width, uint32_t height, std::size_t stride = 0) {
    return image(data, width, height, stride, LFAST_PIXEL_FORMAT_GRAY8);
}

/// Keypoints and descriptors owned by the library, freed on destruction.
class Features {
public:
    Features() = default;
    explicit Features(LfastFeatures* f) : f_(f) {}
    std::size_t size() const noexcept { return f_ ? f_->count : 0; }
    bool empty() const noexcept { return size() == 0; }
    bool has_descriptors() const noexcept { return f_ && f_->descriptors; }
    /// Keypoint i (i < size()).
    const KeyPoint& keypoint(std::size_t i) const { return f_->keypoints[i]; }
    /// The 32 bytes of descriptor i (i < size(); has_descriptors()).
    const uint8_t* descriptor(std::size_t i) const { return f_->descriptors + 32 * i; }
    /// All keypoints (NULL when empty) and all descriptors (size() x 32 bytes, or NULL).
    const KeyPoint* keypoints() const noexcept { return f_ ? f_->keypoints : nullptr; }
    const uint8_t* descriptors() const noexcept { return f_ ? f_->descriptors : nullptr; }
    /// The keypoints as a vector.
    std::vector<KeyPoint> keypoint_vector() const { return {keypoints(), keypoints() + size()}; }

private:
    struct Free {
        void operator()(LfastFeatures* f) const noexcept { lfast_features_free(f); }
    };
    std::unique_ptr<LfastFeatures, Free> f_;
};

/// An 8-bit plane owned by the library (edge maps, images read from files).
class Plane {
public:
    Plane() = default;
    explicit Plane(LfastPlane* p) : p_(p) {}
    uint32_t width() const noexcept { return p_ ? p_->width : 0; }
    uint32_t height() const noexcept { return p_ ? p_->height : 0; }
    /// width() * height() bytes, rows packed.
    const uint8_t* data() const noexcept { return p_ ? p_->data : nullptr; }
    /// The plane as a detector input.
    Image image() const { return gray8(data(), width(), height()); }

private:
    struct Free {
        void operator()(LfastPlane* p) const noexcept { lfast_plane_free(p); }
    };
    std::unique_ptr<LfastPlane, Free> p_;
};

/// Reads an image file as 8-bit gray exactly as `lfast detect` does.
inline Plane imread(const std::string& path) {
    LfastPlane* p = nullptr;
    check(lfast_imread(path.c_str(), &p));
    return Plane(p);
}

/// The detector (movable, not copyable).
class Detector {
public:
    explicit Detector(const Config& config = default_config(), Backend backend = Backend::Auto) {
        LfastDetector* d = nullptr;
        check(lfast_detector_new(&config, static_cast<int32_t>(backend), &d));
        d_.reset(d);
    }
    /// A detector from TOML text (the format of `lfast --config FILE`).
    static Detector from_toml(const std::string& toml, Backend backend = Backend::Auto) {
        LfastDetector* d = nullptr;
        check(lfast_detector_new_toml(toml.c_str(), static_cast<int32_t>(backend), &d));
        return Detector(d);
    }

    /// Keypoints where `mask` (optional, 8-bit gray, image size) is nonzero.
    Features detect(const Image& image, const Image* mask = nullptr) const {
        LfastFeatures* f = nullptr;
        check(lfast_detect(get(), &image, mask, &f));
        return Features(f);
    }
    /// Keypoints and their descriptors.
    Features detect_and_compute(const Image& image, const Image* mask = nullptr) const {
        LfastFeatures* f = nullptr;
        check(lfast_detect_and_compute(get(), &image, mask, &f));
        return Features(f);
    }
    /// Descriptors of given keypoints (each at its octave).
    Features compute(const Image& image, const KeyPoint* keypoints, std::size_t count) const {
        LfastFeatures* f = nullptr;
        check(lfast_compute(get(), &image, keypoints, count, &f));
        return Features(f);
    }
    Features compute(const Image& image, const std::vector<KeyPoint>& keypoints) const {
        return compute(image, keypoints.data(), keypoints.size());
    }
    /// The improved Canny edge map (255 = edge).
    Plane edges(const Image& image) const {
        LfastPlane* p = nullptr;
        check(lfast_edges(get(), &image, &p));
        return Plane(p);
    }
    Config config() const {
        Config c{};
        check(lfast_detector_config(get(), &c));
        return c;
    }
    /// "gpu" or "cpu": where the next frame runs.
    std::string backend() const { return lfast_detector_backend(get()); }
    /// The C handle (owned by this object).
    LfastDetector* get() const noexcept { return d_.get(); }

private:
    explicit Detector(LfastDetector* d) : d_(d) {}
    struct Free {
        void operator()(LfastDetector* d) const noexcept { lfast_detector_free(d); }
    };
    std::unique_ptr<LfastDetector, Free> d_;
};

}  // namespace lfast

#endif  // LFAST_HPP
