/* Embree side of `bench curves`: trace the groom's primary rays against Embree 4's round Bézier
 * curves (RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE, the same swept-sphere tube as ours) and time them.
 *
 * usage: embree_curves DIR
 * DIR holds what `bench curves` wrote: curves.control.f32 (segments × 4 control points × xyzr),
 * curves.rays.f32 (rays × origin xyz, direction xyz) and curves.ours_hit.u8 (1 where our tracer hit).
 * Prints one JSON object: Mrays/s of thread CPU time (one thread, rtcIntersect1 per ray), the
 * fraction of rays hit and how often Embree and we agree on hit or miss.
 *
 * Built against the Embree 4 shared library that embreex ships (no headers there, so the few
 * declarations needed are below, from embree4/rtcore_*.h):
 *   gcc -O2 -o embree_curves bench/embree_curves.c -L$LIBDIR -l:libembree4-4aef3270.so.4 -Wl,-rpath,$LIBDIR
 * with LIBDIR the `embreex.libs` folder of a venv with embreex 4.4.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <math.h>

typedef void *RTCDevice;
typedef void *RTCScene;
typedef void *RTCGeometry;
enum { RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE = 24 };
enum { RTC_BUFFER_TYPE_INDEX = 0, RTC_BUFFER_TYPE_VERTEX = 1 };
enum { RTC_FORMAT_UINT = 0x5001, RTC_FORMAT_FLOAT4 = 0x9004 };
enum { RTC_BUILD_QUALITY_HIGH = 2 };
#define RTC_INVALID_GEOMETRY_ID ((unsigned)-1)

struct RTCRay { float org_x, org_y, org_z, tnear, dir_x, dir_y, dir_z, time, tfar; unsigned mask, id, flags; };
/* instPrimID exists when Embree is built with instance arrays; the padding absorbs it either way. */
struct RTCHit { float Ng_x, Ng_y, Ng_z, u, v; unsigned primID, geomID, instID[1], instPrimID[1], pad[3]; };
struct __attribute__((aligned(16))) RTCRayHit { struct RTCRay ray; struct RTCHit hit; };

RTCDevice rtcNewDevice(const char *config);
RTCScene rtcNewScene(RTCDevice device);
void rtcSetSceneBuildQuality(RTCScene scene, int quality);
RTCGeometry rtcNewGeometry(RTCDevice device, int type);
void *rtcSetNewGeometryBuffer(RTCGeometry g, int type, unsigned slot, int format, size_t stride, size_t count);
void rtcCommitGeometry(RTCGeometry g);
unsigned rtcAttachGeometry(RTCScene scene, RTCGeometry g);
void rtcReleaseGeometry(RTCGeometry g);
void rtcCommitScene(RTCScene scene);
void rtcIntersect1(RTCScene scene, struct RTCRayHit *rayhit, void *args);
int rtcGetDeviceError(RTCDevice device);

static void *slurp(const char *dir, const char *name, size_t *bytes) {
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "rb");
    if (!f) { fprintf(stderr, "cannot open %s\n", path); exit(1); }
    fseek(f, 0, SEEK_END);
    *bytes = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    void *data = malloc(*bytes);
    if (fread(data, 1, *bytes, f) != *bytes) { fprintf(stderr, "short read %s\n", path); exit(1); }
    fclose(f);
    return data;
}

static double cpu_seconds(void) {
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
    if (argc != 2) { fprintf(stderr, "usage: embree_curves DIR\n"); return 2; }
    size_t cbytes, rbytes, hbytes;
    float *control = slurp(argv[1], "curves.control.f32", &cbytes);
    float *rays = slurp(argv[1], "curves.rays.f32", &rbytes);
    uint8_t *ours = slurp(argv[1], "curves.ours_hit.u8", &hbytes);
    size_t segments = cbytes / (16 * sizeof(float)), n = rbytes / (6 * sizeof(float));
    if (hbytes != n) { fprintf(stderr, "ray and hit counts differ\n"); return 1; }
    RTCDevice device = rtcNewDevice("threads=1");
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    double build = cpu_seconds();
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_ROUND_BEZIER_CURVE);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 16, segments * 4);
    memcpy(v, control, cbytes);
    unsigned *idx = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT, 4, segments);
    for (size_t i = 0; i < segments; i++) idx[i] = (unsigned)(4 * i);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(scene);
    build = cpu_seconds() - build;
    if (rtcGetDeviceError(device)) { fprintf(stderr, "embree error %d\n", rtcGetDeviceError(device)); return 1; }
    double best = INFINITY;
    size_t hits = 0, agree = 0;
    for (int repeat = 0; repeat < 3; repeat++) {
        hits = agree = 0;
        double start = cpu_seconds();
        for (size_t i = 0; i < n; i++) {
            const float *r = rays + 6 * i;
            struct RTCRayHit rh;
            memset(&rh, 0, sizeof rh);
            rh.ray.org_x = r[0]; rh.ray.org_y = r[1]; rh.ray.org_z = r[2];
            rh.ray.dir_x = r[3]; rh.ray.dir_y = r[4]; rh.ray.dir_z = r[5];
            rh.ray.tnear = 0.0f; rh.ray.tfar = INFINITY; rh.ray.mask = (unsigned)-1;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &rh, NULL);
            int hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            hits += hit;
            agree += hit == (ours[i] != 0);
        }
        double seconds = cpu_seconds() - start;
        if (seconds < best) best = seconds;
    }
    printf("{\"segments\": %zu, \"rays\": %zu, \"embree_build_s_cpu\": %.4f, \"embree_mrays_1thr_cpu\": %.4f, "
           "\"embree_hit_fraction\": %.5f, \"agree_hit_or_miss\": %.5f}\n",
           segments, n, build, n / best / 1e6, (double)hits / n, (double)agree / n);
    return 0;
}
