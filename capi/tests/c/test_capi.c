/* C test of the lfast C ABI (capi/include/lfast/lfast.h), run by .ci/run
 * under valgrind:
 *
 *   test_capi DUMP_DIR [--config TOML_FILE] IMAGE...
 *
 * For each image it writes DUMP_DIR/<name>.features (one line a keypoint:
 * the bits of x y size angle response as hex, octave, class_id, descriptor
 * as 64 hex digits), which capi/tests/compare_features.py compares with
 * `lfast detect`'s JSON. It checks that every input format (strided gray
 * 8/16, BGR/BGRA 8/16) gives the same features, detect/compute/edges agree
 * with detect_and_compute, a mask is honoured, two threads on one detector
 * get the single-thread results, and bad input gives an error code and a
 * message, never a crash. Exit 0 when all checks pass. */
#include <lfast/lfast.h>

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

static void fail(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "FAIL: ");
    vfprintf(stderr, fmt, ap);
    fprintf(stderr, "\n");
    va_end(ap);
    failures++;
}

#define CHECK(cond, ...)                 \
    do {                                 \
        if (!(cond)) fail(__VA_ARGS__);  \
    } while (0)

static void *xmalloc(size_t n) {
    void *p = malloc(n ? n : 1);
    if (!p) {
        fprintf(stderr, "out of memory\n");
        exit(2);
    }
    return p;
}

/* Same keypoints (bit for bit) and, when both have them, the same descriptors. */
static int same_features(const LfastFeatures *a, const LfastFeatures *b) {
    if (a->count != b->count) return 0;
    if (a->count == 0) return 1;
    if (memcmp(a->keypoints, b->keypoints, a->count * sizeof(LfastKeyPoint)) != 0) return 0;
    if (a->descriptors && b->descriptors && memcmp(a->descriptors, b->descriptors, a->count * 32) != 0) return 0;
    return 1;
}

static unsigned bits(float f) {
    unsigned u;
    memcpy(&u, &f, sizeof u);
    return u;
}

static void dump(const char *dir, const char *image_path, const LfastFeatures *f) {
    const char *slash = strrchr(image_path, '/');
    const char *name = slash ? slash + 1 : image_path;
    size_t n = strlen(dir) + strlen(name) + 16;
    char *path = xmalloc(n);
    snprintf(path, n, "%s/%s.features", dir, name);
    FILE *out = fopen(path, "w");
    if (!out) {
        fail("cannot write %s", path);
        free(path);
        return;
    }
    for (size_t i = 0; i < f->count; i++) {
        const LfastKeyPoint *k = &f->keypoints[i];
        fprintf(out, "%08x %08x %08x %08x %08x %d %d ", bits(k->x), bits(k->y), bits(k->size), bits(k->angle),
                bits(k->response), k->octave, k->class_id);
        for (int j = 0; j < 32; j++) fprintf(out, "%02x", f->descriptors[32 * i + j]);
        fprintf(out, "\n");
    }
    fclose(out);
    free(path);
}

/* The gray plane re-laid as `format` with `pad` bytes after each row; every
 * format reads back as the same gray (equal channels, 16-bit low bytes dropped). */
static unsigned char *relayout(const LfastPlane *g, LfastPixelFormat format, size_t pad, LfastImage *img) {
    static const size_t channels[] = {1, 1, 3, 3, 4, 4}, sample[] = {1, 2, 1, 2, 1, 2};
    size_t c = channels[format], s = sample[format];
    size_t stride = g->width * c * s + pad;
    unsigned char *buf = xmalloc(stride * g->height);
    memset(buf, 0xa5, stride * g->height);
    for (uint32_t y = 0; y < g->height; y++) {
        for (uint32_t x = 0; x < g->width; x++) {
            uint8_t v = g->data[(size_t)y * g->width + x];
            for (size_t ch = 0; ch < c; ch++) {
                unsigned char *p = buf + y * stride + (x * c + ch) * s;
                uint8_t val = ch == 3 ? 0x11 : v; /* alpha is ignored */
                if (s == 1) {
                    *p = val;
                } else {
                    uint16_t w = (uint16_t)((val << 8) | 0x7f);
                    memcpy(p, &w, 2);
                }
            }
        }
    }
    img->data = buf;
    img->width = g->width;
    img->height = g->height;
    img->stride = stride;
    img->format = format;
    return buf;
}

/* ---------------------------------------------------------------- threads */

struct job {
    const LfastDetector *det;
    const LfastImage *img;
    const LfastFeatures *want;
    int rounds;
    int ok;
};

static void *worker(void *arg) {
    struct job *j = arg;
    j->ok = 1;
    for (int r = 0; r < j->rounds; r++) {
        LfastFeatures *f = NULL;
        if (lfast_detect_and_compute(j->det, j->img, NULL, &f) != LFAST_STATUS_OK) {
            j->ok = 0;
            break;
        }
        if (!same_features(f, j->want)) j->ok = 0;
        lfast_features_free(f);
    }
    return NULL;
}

/* ---------------------------------------------------------------- bad input */

static void expect_error(LfastStatus got, LfastStatus want, const char *needle, const char *what) {
    const char *msg = lfast_last_error();
    CHECK(got == want, "%s: status %d, expected %d (%s)", what, (int)got, (int)want, msg);
    CHECK(msg && strstr(msg, needle), "%s: message \"%s\" does not contain \"%s\"", what, msg ? msg : "(null)",
          needle);
}

static void bad_input(const LfastDetector *det, const LfastPlane *g) {
    LfastFeatures *sentinel = (LfastFeatures *)(uintptr_t)0x1, *out = sentinel;
    LfastImage ok = {g->data, g->width, g->height, g->width, LFAST_PIXEL_FORMAT_GRAY8};
    LfastImage im;

    expect_error(lfast_detect_and_compute(NULL, &ok, NULL, &out), LFAST_STATUS_NULL_POINTER, "`detector` is NULL",
                 "NULL detector");
    expect_error(lfast_detect_and_compute(det, NULL, NULL, &out), LFAST_STATUS_NULL_POINTER, "`image` is NULL",
                 "NULL image");
    expect_error(lfast_detect_and_compute(det, &ok, NULL, NULL), LFAST_STATUS_NULL_POINTER, "`out` is NULL",
                 "NULL out");
    im = ok;
    im.data = NULL;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_NULL_POINTER, "image.data", "NULL data");
    im = ok;
    im.width = 0;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "empty", "zero width");
    im = ok;
    im.height = 0;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "empty", "zero height");
    im = ok;
    im.stride = g->width - 1;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "less than a row",
                 "stride < width");
    im = ok;
    im.format = LFAST_PIXEL_FORMAT_BGR8; /* a 3-channel row needs 3 * width bytes */
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "less than a row",
                 "BGR with a gray stride");
    im = ok;
    im.format = 7;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "unknown pixel format 7",
                 "wrong channel count");
    im = ok;
    im.format = -1;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "unknown pixel format -1",
                 "negative format");
    im = ok;
    im.width = 100000;
    im.stride = 100000;
    expect_error(lfast_detect(det, &im, NULL, &out), LFAST_STATUS_INVALID_ARGUMENT, "exceeds the limit",
                 "too wide");

    LfastImage small = ok;
    small.width = g->width / 2;
    expect_error(lfast_detect(det, &ok, &small, &out), LFAST_STATUS_INVALID_ARGUMENT, "mask is", "mask size");
    LfastImage m16 = ok;
    m16.format = LFAST_PIXEL_FORMAT_GRAY16;
    m16.width = g->width / 2;
    expect_error(lfast_detect(det, &ok, &m16, &out), LFAST_STATUS_INVALID_ARGUMENT, "GRAY8", "16-bit mask");

    LfastKeyPoint kp = {10.0f, 10.0f, 31.0f, -1.0f, 0.0f, 99, -1};
    expect_error(lfast_compute(det, &ok, &kp, 1, &out), LFAST_STATUS_INVALID_ARGUMENT, "keypoint 0: octave 99",
                 "octave out of range");
    kp.octave = 0;
    kp.x = -5.0f;
    expect_error(lfast_compute(det, &ok, &kp, 1, &out), LFAST_STATUS_INVALID_ARGUMENT, "outside level 0",
                 "keypoint outside");
    expect_error(lfast_compute(det, &ok, NULL, 3, &out), LFAST_STATUS_NULL_POINTER, "`keypoints` is NULL",
                 "NULL keypoints");

    LfastPlane *pl = (LfastPlane *)(uintptr_t)0x1;
    expect_error(lfast_edges(det, NULL, &pl), LFAST_STATUS_NULL_POINTER, "`image` is NULL", "edges NULL image");
    expect_error(lfast_imread("/nonexistent/lfast.png", &pl), LFAST_STATUS_IO, "/nonexistent/lfast.png",
                 "missing file");
    expect_error(lfast_imread(NULL, &pl), LFAST_STATUS_NULL_POINTER, "`path` is NULL", "NULL path");
    CHECK(pl == (LfastPlane *)(uintptr_t)0x1, "a failed call wrote its output");

    LfastDetector *d = (LfastDetector *)(uintptr_t)0x1;
    LfastConfig c = lfast_config_default();
    c.support = 0;
    expect_error(lfast_detector_new(&c, LFAST_BACKEND_CPU, &d), LFAST_STATUS_INVALID_CONFIG, "`support`",
                 "bad support");
    expect_error(lfast_config_validate(&c), LFAST_STATUS_INVALID_CONFIG, "`support`", "validate support");
    c = lfast_config_default();
    c.mode = 3;
    expect_error(lfast_detector_new(&c, LFAST_BACKEND_CPU, &d), LFAST_STATUS_INVALID_CONFIG, "`mode`", "bad mode");
    c = lfast_config_default();
    c.scale_factor = 1.0;
    expect_error(lfast_detector_new(&c, LFAST_BACKEND_CPU, &d), LFAST_STATUS_INVALID_CONFIG, "`scale_factor`",
                 "bad scale");
    expect_error(lfast_detector_new(NULL, 9, &d), LFAST_STATUS_INVALID_ARGUMENT, "backend", "bad backend");
    expect_error(lfast_detector_new(NULL, LFAST_BACKEND_CPU, NULL), LFAST_STATUS_NULL_POINTER, "`out` is NULL",
                 "new NULL out");
    expect_error(lfast_detector_new_toml("n_levels = \"x\"", LFAST_BACKEND_CPU, &d), LFAST_STATUS_INVALID_CONFIG,
                 "n_levels", "bad toml");
    expect_error(lfast_detector_new_toml("no_such_field = 1", LFAST_BACKEND_CPU, &d), LFAST_STATUS_INVALID_CONFIG,
                 "no_such_field", "unknown toml field");
    expect_error(lfast_config_validate(NULL), LFAST_STATUS_NULL_POINTER, "`config` is NULL", "validate NULL");
    expect_error(lfast_detector_config(NULL, &c), LFAST_STATUS_NULL_POINTER, "`detector` is NULL", "config NULL");
    CHECK(d == (LfastDetector *)(uintptr_t)0x1, "a failed constructor wrote its output");
    CHECK(out == sentinel, "a failed call wrote its output");
    CHECK(lfast_detector_backend(NULL) == NULL, "backend of NULL is not NULL");
    lfast_detector_free(NULL);
    lfast_features_free(NULL);
    lfast_plane_free(NULL);
}

/* ---------------------------------------------------------------- per image */

static void check_image(const LfastDetector *det, const char *dir, const char *path, int variants) {
    LfastPlane *g = NULL;
    if (lfast_imread(path, &g) != LFAST_STATUS_OK) {
        fail("%s: %s", path, lfast_last_error());
        return;
    }
    LfastImage dense = {g->data, g->width, g->height, g->width, LFAST_PIXEL_FORMAT_GRAY8};
    LfastFeatures *f = NULL;
    if (lfast_detect_and_compute(det, &dense, NULL, &f) != LFAST_STATUS_OK) {
        fail("%s: %s", path, lfast_last_error());
        lfast_plane_free(g);
        return;
    }
    printf("%s: %ux%u, %zu keypoints\n", path, g->width, g->height, f->count);
    CHECK(f->count > 0 && f->keypoints && f->descriptors, "%s: no features", path);
    dump(dir, path, f);

    /* every pixel format and a padded stride give the same features */
    for (int fmt = LFAST_PIXEL_FORMAT_GRAY8; variants && fmt <= LFAST_PIXEL_FORMAT_BGRA16; fmt++) {
        LfastImage im;
        unsigned char *buf = relayout(g, (LfastPixelFormat)fmt, 3 + (size_t)fmt, &im);
        LfastFeatures *h = NULL;
        LfastStatus s = lfast_detect_and_compute(det, &im, NULL, &h);
        CHECK(s == LFAST_STATUS_OK && same_features(f, h), "%s: format %d differs (%s)", path, fmt,
              s ? lfast_last_error() : "features");
        lfast_features_free(h);
        free(buf);
    }

    /* detect = the keypoints of detect_and_compute, without descriptors */
    LfastFeatures *k = NULL;
    CHECK(lfast_detect(det, &dense, NULL, &k) == LFAST_STATUS_OK, "%s: detect: %s", path, lfast_last_error());
    CHECK(k && same_features(f, k) && k->descriptors == NULL, "%s: detect differs", path);
    lfast_features_free(k);

    /* compute of the detected keypoints = the same descriptors */
    LfastFeatures *c = NULL;
    CHECK(lfast_compute(det, &dense, f->keypoints, f->count, &c) == LFAST_STATUS_OK, "%s: compute: %s", path,
          lfast_last_error());
    CHECK(c && same_features(f, c) && c->descriptors, "%s: compute differs", path);
    lfast_features_free(c);

    if (variants) {
        /* a mask that zeroes the left half: every keypoint lies right of it */
        unsigned char *mask = xmalloc((size_t)g->width * g->height);
        memset(mask, 255, (size_t)g->width * g->height);
        for (uint32_t y = 0; y < g->height; y++) memset(mask + (size_t)y * g->width, 0, g->width / 2);
        LfastImage mi = {mask, g->width, g->height, g->width, LFAST_PIXEL_FORMAT_GRAY8};
        LfastFeatures *m = NULL;
        CHECK(lfast_detect_and_compute(det, &dense, &mi, &m) == LFAST_STATUS_OK, "%s: mask: %s", path,
              lfast_last_error());
        if (m) {
            CHECK(m->count < f->count, "%s: the mask removed nothing", path);
            for (size_t i = 0; i < m->count; i++)
                CHECK(m->keypoints[i].x >= (float)(g->width / 2), "%s: keypoint %zu at x %g is masked", path, i,
                      (double)m->keypoints[i].x);
        }
        lfast_features_free(m);
        free(mask);

        /* edges: 0 or 255, the image's size */
        LfastPlane *e = NULL;
        CHECK(lfast_edges(det, &dense, &e) == LFAST_STATUS_OK, "%s: edges: %s", path, lfast_last_error());
        if (e) {
            size_t on = 0;
            CHECK(e->width == g->width && e->height == g->height, "%s: edge map size", path);
            for (size_t i = 0; i < (size_t)e->width * e->height; i++) {
                CHECK(e->data[i] == 0 || e->data[i] == 255, "%s: edge value %d", path, e->data[i]);
                on += e->data[i] == 255;
            }
            CHECK(on > 0, "%s: no edges", path);
        }
        lfast_plane_free(e);

        bad_input(det, g);

        /* two threads on one detector give the single-thread results */
        struct job jobs[2] = {{det, &dense, f, 3, 0}, {det, &dense, f, 3, 0}};
        pthread_t t[2];
        for (int i = 0; i < 2; i++) pthread_create(&t[i], NULL, worker, &jobs[i]);
        for (int i = 0; i < 2; i++) pthread_join(t[i], NULL);
        CHECK(jobs[0].ok && jobs[1].ok, "%s: concurrent calls differ", path);
    }
    lfast_features_free(f);
    lfast_plane_free(g);
}

static char *read_file(const char *path) {
    FILE *in = fopen(path, "rb");
    if (!in) return NULL;
    fseek(in, 0, SEEK_END);
    long n = ftell(in);
    fseek(in, 0, SEEK_SET);
    char *s = xmalloc((size_t)n + 1);
    size_t got = fread(s, 1, (size_t)n, in);
    s[got] = 0;
    fclose(in);
    return s;
}

int main(int argc, char **argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s DUMP_DIR [--config TOML_FILE] IMAGE...\n", argv[0]);
        return 2;
    }
    const char *dir = argv[1];
    int first = 2;
    LfastDetector *det = NULL;
    CHECK(strlen(lfast_version()) > 0, "empty version");
    CHECK(strcmp(lfast_last_error(), "") == 0, "an error before any call");
    if (argc > 4 && strcmp(argv[2], "--config") == 0) {
        char *toml = read_file(argv[3]);
        if (!toml) {
            fprintf(stderr, "cannot read %s\n", argv[3]);
            return 2;
        }
        CHECK(lfast_detector_new_toml(toml, LFAST_BACKEND_CPU, &det) == LFAST_STATUS_OK, "config %s: %s", argv[3],
              lfast_last_error());
        free(toml);
        first = 4;
        /* the same config through the struct gives the same detector settings */
        LfastConfig c;
        LfastDetector *d2 = NULL;
        if (det && lfast_detector_config(det, &c) == LFAST_STATUS_OK) {
            CHECK(lfast_detector_new(&c, LFAST_BACKEND_CPU, &d2) == LFAST_STATUS_OK, "struct config: %s",
                  lfast_last_error());
            lfast_detector_free(d2);
        }
    } else {
        LfastConfig c = lfast_config_default();
        CHECK(lfast_config_validate(&c) == LFAST_STATUS_OK, "defaults invalid: %s", lfast_last_error());
        CHECK(c.n_levels == 8 && c.scale_factor > 1.19 && c.scale_factor < 1.21, "unexpected defaults");
        CHECK(lfast_detector_new(&c, LFAST_BACKEND_CPU, &det) == LFAST_STATUS_OK, "new: %s", lfast_last_error());
    }
    if (!det) return 1;
    CHECK(strcmp(lfast_detector_backend(det), "cpu") == 0, "backend is %s", lfast_detector_backend(det));
    for (int i = first; i < argc; i++) check_image(det, dir, argv[i], i == first);
    lfast_detector_free(det);
    if (failures) {
        fprintf(stderr, "%d check(s) failed\n", failures);
        return 1;
    }
    printf("all C checks passed\n");
    return 0;
}
