// orbslam3_kitti: runs ORB-SLAM3 (monocular or stereo, no viewer) over a
// KITTI-format sequence and writes per-frame results for
// scripts/orbslam3/run.sh.
//
//   orbslam3_kitti VOCABULARY SETTINGS SEQ_DIR OUT_DIR --sensor mono|stereo
//                  [--first N] [--last N] [--pace lockstep|free|realtime]
//
// SEQ_DIR: image_0/NNNNNN.png (image_1/ for stereo), times.txt (10 Hz when
// absent). Frames FIRST..LAST (default: all of image_0).
//
// Pacing (--pace):
//   lockstep (default)  LocalMapping is held while a frame is tracked (it
//                       starts on the frame's keyframe once Track* returns);
//                       then the driver waits until LocalMapping has an empty
//                       queue and accepts keyframes again, LoopClosing has
//                       processed its queue, and no global BA runs; only then
//                       is the next frame fed. Tracking, mapping and loop
//                       detection take turns as if one thread did all the
//                       work, and mapping always keeps up, so the result does
//                       not depend on the machine's speed or load. Needs
//                       patch 0006.
//   free                frames fed as fast as tracking returns (monocular KITTI
//                       fails this way: LocalMapping is still busy with the
//                       initial map when tracking needs its next keyframes)
//   realtime            upstream's pacing: wait out the time to the next
//                       timestamp
//
// OUT_DIR/frames.csv, one row per frame:
//   frame         index in image_0 (= row of the ground truth)
//   timestamp     from times.txt
//   state         tracking state after the frame: NOT_INITIALIZED, OK,
//                 RECENTLY_LOST, LOST, ...
//   keypoints     keypoints the extractor returned for the (left) image; before
//                 monocular initialisation ORB-SLAM3 asks 5 x nFeatures
//   keypoints_right  the same for the right image (stereo), else 0
//   ini_extractor 1 if the frame was extracted by the initialisation
//                 extractor (monocular, before and just after initialising:
//                 5 x nFeatures asked), else 0
//   extract_ms    ORB extraction in Frame's constructor (Frame::mTimeORB_Ext,
//                 patch 0008; stereo: both images, in two threads)
//   track_ms      the whole Track* call
//   wait_ms       time spent waiting for the mapping threads (lockstep)
//   map_id        the atlas's current map after the frame
//   tracked       1 if the frame's pose is scored: tracked OK, and its
//                 reference keyframe belongs to the final map; frames of maps
//                 that were reset or replaced count as lost (0)
// OUT_DIR/trajectory.txt: KITTI poses (camera to world, 3x4 row-major) of the
//   tracked frames, in order, in the final map's frame (first keyframe at
//   the origin), from Tracking's per-frame poses relative to their
//   (optimised) reference keyframes as SaveTrajectoryTUM composes them.
// OUT_DIR/trajectory_frames.txt: the frame index of each trajectory row.
// OUT_DIR/summary.json: counts (frames, tracked, the first tracked frame,
//   keyframes and map points of the final map, maps, resets: times tracking
//   fell back to initialising) and per-frame medians (keypoints, extraction
//   ms; "_ini" for the initialisation extractor's frames).
// OUT_DIR/CameraTrajectory_upstream.txt, KeyFrameTrajectory_upstream.txt:
//   ORB-SLAM3's own SaveTrajectoryTUM / SaveKeyFrameTrajectoryTUM, for reference.
//
// Links ORB-SLAM3 (GPLv3; the program built is GPLv3). This source file is
// part of lfast: SPDX-License-Identifier: MIT OR Apache-2.0

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/stat.h>

#include <opencv2/core/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "Atlas.h"
#include "KeyFrame.h"
#include "LocalMapping.h"
#include "Lockstep.h"
#include "LoopClosing.h"
#include "Map.h"
#include "System.h"
#include "Tracking.h"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

struct Args {
    std::string vocabulary, settings, seq, out;
    bool stereo = false;
    long first = 0, last = -1;
    std::string pace = "lockstep";
};

[[noreturn]] void fail(const std::string& msg) {
    std::cerr << "orbslam3_kitti: " << msg << std::endl;
    std::exit(2);
}

bool parse_long(const std::string& s, long& out) {
    char* end = nullptr;
    errno = 0;
    long v = std::strtol(s.c_str(), &end, 10);
    if (s.empty() || *end != '\0' || errno != 0 || v < 0) return false;
    out = v;
    return true;
}

Args parse_args(int argc, char** argv) {
    Args a;
    std::vector<std::string> pos;
    for (int i = 1; i < argc; ++i) {
        std::string s = argv[i];
        auto value = [&](const char* name) -> std::string {
            if (i + 1 >= argc) fail(std::string(name) + " needs a value");
            return argv[++i];
        };
        if (s == "--sensor") {
            std::string v = value("--sensor");
            if (v == "mono")
                a.stereo = false;
            else if (v == "stereo")
                a.stereo = true;
            else
                fail("--sensor: '" + v + "' is not mono or stereo");
        } else if (s == "--first") {
            if (!parse_long(value("--first"), a.first)) fail("--first needs a frame index >= 0");
        } else if (s == "--last") {
            if (!parse_long(value("--last"), a.last)) fail("--last needs a frame index >= 0");
        } else if (s == "--pace") {
            a.pace = value("--pace");
            if (a.pace != "lockstep" && a.pace != "free" && a.pace != "realtime")
                fail("--pace: '" + a.pace + "' is not lockstep, free or realtime");
        } else if (!s.empty() && s[0] == '-') {
            fail("unknown option '" + s + "'");
        } else {
            pos.push_back(s);
        }
    }
    if (pos.size() != 4)
        fail("usage: orbslam3_kitti VOCABULARY SETTINGS SEQ_DIR OUT_DIR --sensor mono|stereo "
             "[--first N] [--last N] [--pace lockstep|free|realtime]");
    a.vocabulary = pos[0];
    a.settings = pos[1];
    a.seq = pos[2];
    a.out = pos[3];
    return a;
}

bool exists(const std::string& p) {
    struct stat st;
    return stat(p.c_str(), &st) == 0;
}

std::string image_path(const std::string& seq, int cam, long i) {
    std::ostringstream s;
    s << seq << "/image_" << cam << "/" << std::setfill('0') << std::setw(6) << i << ".png";
    return s.str();
}

const char* state_name(int s) {
    switch (s) {
        case ORB_SLAM3::Tracking::SYSTEM_NOT_READY: return "SYSTEM_NOT_READY";
        case ORB_SLAM3::Tracking::NO_IMAGES_YET: return "NO_IMAGES_YET";
        case ORB_SLAM3::Tracking::NOT_INITIALIZED: return "NOT_INITIALIZED";
        case ORB_SLAM3::Tracking::OK: return "OK";
        case ORB_SLAM3::Tracking::RECENTLY_LOST: return "RECENTLY_LOST";
        case ORB_SLAM3::Tracking::LOST: return "LOST";
        case ORB_SLAM3::Tracking::OK_KLT: return "OK_KLT";
        default: return "UNKNOWN";
    }
}

struct FrameRow {
    long frame = 0;
    double timestamp = 0;
    int state = 0;
    int keypoints = 0, keypoints_right = 0;
    bool ini_extractor = false;
    double extract_ms = 0, track_ms = 0, wait_ms = 0;
    long map_id = -1;
    bool tracked = false;
};

// The median as JSON (null when there is none).
std::string median_json(std::vector<double> v) {
    if (v.empty()) return "null";
    std::sort(v.begin(), v.end());
    size_t n = v.size();
    std::ostringstream s;
    s << std::setprecision(6) << (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
    return s.str();
}

bool is_tracking(int state) {
    return state == ORB_SLAM3::Tracking::OK || state == ORB_SLAM3::Tracking::RECENTLY_LOST ||
           state == ORB_SLAM3::Tracking::LOST || state == ORB_SLAM3::Tracking::OK_KLT;
}

// The mapping threads have done all the work the last frame gave them.
bool mapping_idle(ORB_SLAM3::System& slam) {
    ORB_SLAM3::LocalMapping* lm = slam.GetLocalMapper();
    ORB_SLAM3::LoopClosing* lc = slam.GetLoopCloser();
    return lm->KeyframesInQueue() == 0 && lm->AcceptKeyFrames() && !lc->IsBusy() && !lc->isRunningGBA();
}

}  // namespace

int main(int argc, char** argv) {
    Args a = parse_args(argc, argv);
    for (const std::string& p : {a.vocabulary, a.settings, a.seq + "/image_0"})
        if (!exists(p)) fail("not found: " + p);
    if (a.stereo && !exists(a.seq + "/image_1")) fail("stereo needs " + a.seq + "/image_1");
    if (!exists(a.out) && mkdir(a.out.c_str(), 0755) != 0) fail("cannot create " + a.out);

    // frames: image_0/000000.png ... up to the first gap
    long count = 0;
    while (exists(image_path(a.seq, 0, count))) ++count;
    if (count == 0) fail("no image_0/000000.png in " + a.seq);
    long last = a.last < 0 ? count - 1 : a.last;
    if (a.first > last || last >= count)
        fail("frames " + std::to_string(a.first) + ".." + std::to_string(last) + " outside 0.." +
             std::to_string(count - 1) + " of " + a.seq);
    std::vector<double> times;
    std::ifstream tf(a.seq + "/times.txt");
    if (tf) {
        for (double t; tf >> t;) times.push_back(t);
        if (static_cast<long>(times.size()) <= last)
            fail(a.seq + "/times.txt has " + std::to_string(times.size()) + " timestamps, frame " +
                 std::to_string(last) + " needs more");
    } else {
        for (long i = 0; i <= last; ++i) times.push_back(0.1 * static_cast<double>(i));  // KITTI's 10 Hz
    }
    for (long i = a.first; i <= last; ++i) {
        if (a.stereo && !exists(image_path(a.seq, 1, i))) fail("missing " + image_path(a.seq, 1, i));
    }

    ORB_SLAM3::System slam(a.vocabulary, a.settings,
                           a.stereo ? ORB_SLAM3::System::STEREO : ORB_SLAM3::System::MONOCULAR, false);
    ORB_SLAM3::Tracking* tracker = slam.GetTracker();
    ORB_SLAM3::Atlas* atlas = slam.GetAtlas();

    std::vector<FrameRow> rows;
    // Tracking appends one entry to its per-frame lists for each frame
    // tracked OK or RECENTLY_LOST: entry_frame[k] is the row of entry k.
    std::vector<size_t> entry_frame;
    // monocular: the first frame is always extracted by Tracking's
    // initialisation extractor (mpIniORBextractor, protected): remember it
    const void* ini_extractor = nullptr;
    int resets = 0;
    for (long i = a.first; i <= last; ++i) {
        cv::Mat left = cv::imread(image_path(a.seq, 0, i), cv::IMREAD_UNCHANGED);
        cv::Mat right;
        if (left.empty()) fail("cannot read " + image_path(a.seq, 0, i));
        if (a.stereo) {
            right = cv::imread(image_path(a.seq, 1, i), cv::IMREAD_UNCHANGED);
            if (right.empty()) fail("cannot read " + image_path(a.seq, 1, i));
        }
        FrameRow r;
        r.frame = i;
        r.timestamp = times[i];
        size_t entries_before = tracker->mlRelativeFramePoses.size();
        const bool lockstep = a.pace == "lockstep";
        if (lockstep) ORB_SLAM3::gHoldLocalMapping = true;
        Clock::time_point t0 = Clock::now();
        if (a.stereo)
            slam.TrackStereo(left, right, r.timestamp);
        else
            slam.TrackMonocular(left, r.timestamp);
        r.track_ms = ms_since(t0);
        if (lockstep) ORB_SLAM3::gHoldLocalMapping = false;
        r.state = tracker->mState;
        // after a reset mCurrentFrame is an empty Frame(): its N is not set
        const ORB_SLAM3::Frame& f = tracker->mCurrentFrame;
        r.keypoints = static_cast<int>(f.mvKeys.size());
        r.keypoints_right = a.stereo ? static_cast<int>(f.mvKeysRight.size()) : 0;
        r.extract_ms = f.mTimeORB_Ext;
        if (!r.keypoints) r.extract_ms = 0;  // not known after a reset
        if (!a.stereo && r.keypoints) {
            if (!ini_extractor) ini_extractor = f.mpORBextractorLeft;
            r.ini_extractor = f.mpORBextractorLeft == ini_extractor;
        }
        if (!rows.empty() && is_tracking(rows.back().state) && !is_tracking(r.state)) ++resets;
        r.map_id = static_cast<long>(atlas->GetCurrentMap()->GetId());
        size_t entries = tracker->mlRelativeFramePoses.size();
        if (entries < entries_before) entry_frame.clear();  // a full reset cleared the lists
        if (entries == entry_frame.size() + 1)
            entry_frame.push_back(rows.size());
        else if (entries != entry_frame.size())
            fail("frame " + std::to_string(i) + ": tracking's pose list grew by " +
                 std::to_string(entries - entry_frame.size()) + " entries");

        Clock::time_point w0 = Clock::now();
        if (lockstep) {
            while (!mapping_idle(slam)) std::this_thread::sleep_for(std::chrono::microseconds(500));
        } else if (a.pace == "realtime" && i < last) {
            double gap = (times[i + 1] - times[i]) * 1e3 - r.track_ms;
            if (gap > 0) std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(gap));
        }
        r.wait_ms = ms_since(w0);
        rows.push_back(r);
        std::fprintf(stderr, "frame %ld %s keypoints %d extract %.1f ms track %.1f ms wait %.1f ms\n", i,
                     state_name(r.state), r.keypoints, r.extract_ms, r.track_ms, r.wait_ms);
    }

    slam.Shutdown();

    // The final map and its origin (its first keyframe), as SaveTrajectoryTUM.
    ORB_SLAM3::Map* final_map = atlas->GetCurrentMap();
    std::vector<ORB_SLAM3::KeyFrame*> kfs = final_map->GetAllKeyFrames();
    std::sort(kfs.begin(), kfs.end(), ORB_SLAM3::KeyFrame::lId);
    std::vector<Sophus::SE3f> twc(rows.size());
    if (!kfs.empty()) {
        Sophus::SE3f Two = kfs[0]->GetPoseInverse();
        auto lit = tracker->mlRelativeFramePoses.begin();
        auto rit = tracker->mlpReferences.begin();
        auto bit = tracker->mlbLost.begin();
        for (size_t k = 0; k < entry_frame.size(); ++k, ++lit, ++rit, ++bit) {
            FrameRow& r = rows[entry_frame[k]];
            ORB_SLAM3::KeyFrame* kf = *rit;
            if (*bit || r.state != ORB_SLAM3::Tracking::OK || !kf) continue;
            Sophus::SE3f Trw;
            while (kf && kf->isBad()) {
                Trw = Trw * kf->mTcp;
                kf = kf->GetParent();
            }
            if (!kf || kf->GetMap() != final_map) continue;
            Trw = Trw * kf->GetPose() * Two;
            twc[entry_frame[k]] = ((*lit) * Trw).inverse();
            r.tracked = true;
        }
    }

    std::ofstream csv(a.out + "/frames.csv");
    std::ofstream traj(a.out + "/trajectory.txt");
    std::ofstream trajf(a.out + "/trajectory_frames.txt");
    csv << "frame,timestamp,state,keypoints,keypoints_right,ini_extractor,extract_ms,track_ms,wait_ms,map_id,"
           "tracked\n";
    // medians over the frames of the regular extractor (nFeatures asked) and
    // of the initialisation one (5 x nFeatures)
    std::vector<double> extract, extract_ini, track, kps, kps_ini, kps_right;
    long tracked = 0, first_tracked = -1;
    for (size_t k = 0; k < rows.size(); ++k) {
        const FrameRow& r = rows[k];
        csv << r.frame << "," << std::fixed << std::setprecision(6) << r.timestamp << "," << state_name(r.state)
            << "," << r.keypoints << "," << r.keypoints_right << "," << (r.ini_extractor ? 1 : 0) << ","
            << std::setprecision(3) << r.extract_ms << ","
            << r.track_ms << "," << r.wait_ms << "," << r.map_id << "," << (r.tracked ? 1 : 0) << "\n";
        if (r.keypoints > 0) {
            (r.ini_extractor ? extract_ini : extract).push_back(r.extract_ms);
            (r.ini_extractor ? kps_ini : kps).push_back(r.keypoints);
            if (a.stereo) kps_right.push_back(r.keypoints_right);
        }
        track.push_back(r.track_ms);
        if (!r.tracked) continue;
        ++tracked;
        if (first_tracked < 0) first_tracked = r.frame;
        Eigen::Matrix3f R = twc[k].rotationMatrix();
        Eigen::Vector3f t = twc[k].translation();
        traj << std::defaultfloat << std::setprecision(9) << R(0, 0) << " " << R(0, 1) << " " << R(0, 2) << " "
             << t(0) << " " << R(1, 0) << " " << R(1, 1) << " " << R(1, 2) << " " << t(1) << " " << R(2, 0) << " "
             << R(2, 1) << " " << R(2, 2) << " " << t(2) << "\n";
        trajf << r.frame << "\n";
    }
    csv.close();
    traj.close();
    trajf.close();
    if (!csv || !traj || !trajf) fail("cannot write the results under " + a.out);

    std::ofstream js(a.out + "/summary.json");
    js << "{\n"
       << "  \"sensor\": \"" << (a.stereo ? "stereo" : "mono") << "\",\n"
       << "  \"pace\": \"" << a.pace << "\",\n"
       << "  \"first\": " << a.first << ",\n  \"last\": " << last << ",\n"
       << "  \"frames\": " << rows.size() << ",\n"
       << "  \"tracked\": " << tracked << ",\n"
       << "  \"first_tracked\": " << first_tracked << ",\n"
       << "  \"keyframes\": " << kfs.size() << ",\n"
       << "  \"map_points\": " << final_map->MapPointsInMap() << ",\n"
       << "  \"maps\": " << atlas->CountMaps() << ",\n"
       << "  \"resets\": " << resets << ",\n"
       << "  \"final_map_id\": " << final_map->GetId() << ",\n"
       << "  \"extract_ms_median\": " << median_json(extract) << ",\n"
       << "  \"extract_ms_median_ini\": " << median_json(extract_ini) << ",\n"
       << "  \"track_ms_median\": " << median_json(track) << ",\n"
       << "  \"keypoints_median\": " << median_json(kps) << ",\n"
       << "  \"keypoints_median_ini\": " << median_json(kps_ini) << ",\n"
       << "  \"keypoints_right_median\": " << median_json(kps_right) << "\n}\n";
    js.close();
    if (!js) fail("cannot write " + a.out + "/summary.json");

    if (!kfs.empty()) {  // both index the first keyframe
        slam.SaveTrajectoryTUM(a.out + "/CameraTrajectory_upstream.txt");
        slam.SaveKeyFrameTrajectoryTUM(a.out + "/KeyFrameTrajectory_upstream.txt");
    }
    std::fprintf(stderr, "%ld of %zu frames tracked in the final map (%zu keyframes)\n", tracked, rows.size(),
                 kfs.size());
    return 0;
}
