/* accel.c - the Embree acceleration structure (see accel.h), for Embree 3 or 4: the build
 * defines OPALINE_EMBREE_MAJOR, and the two differences that matter here (the header, and the
 * intersection context of Embree 3 against the optional arguments of Embree 4) stay in this
 * file's first lines. */
#include "geometry/accel.h"

#if OPALINE_EMBREE_MAJOR >= 4
#include <embree4/rtcore.h>
/* Embree 4: the default arguments (no filter, coherent flags off) match Embree 3's default
 * context. */
static void rtc_intersect(RTCScene s, struct RTCRayHit *rh)
{
    rtcIntersect1(s, rh, NULL);
}
static void rtc_occluded(RTCScene s, struct RTCRay *r)
{
    rtcOccluded1(s, r, NULL);
}
#elif OPALINE_EMBREE_MAJOR == 3
#include <embree3/rtcore.h>
static void rtc_intersect(RTCScene s, struct RTCRayHit *rh)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcIntersect1(s, &ctx, rh);
}
static void rtc_occluded(RTCScene s, struct RTCRay *r)
{
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcOccluded1(s, &ctx, r);
}
#else
#error "OPALINE_EMBREE_MAJOR must be 3 or 4 (set by cmake/OpalineDependencies.cmake)"
#endif
#include <limits.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <unistd.h>

struct op_accel {
    RTCDevice device;
    RTCScene scene;
    RTCScene *protos;           /* one Embree scene per mesh shared by instances */
    int nprotos;
    const op_placement **place; /* per shape: its placement, or NULL */
    atomic_llong bytes;         /* Embree's allocations minus its frees */
    long long budget;           /* the most bytes Embree may hold (see address_space_budget) */
    char error[512]; /* the device's last error, written by the error callback during builds */
    enum RTCError code; /* and its code */
    int building;       /* in op_accel_build, which returns the error instead of logging it */
    atomic_int refused; /* the memory monitor refused an allocation over the budget */
};

/* Embree reports its errors here; during a build only the building thread calls it. */
static void device_error(void *user, enum RTCError code, const char *str)
{
    op_accel *a = user;
    snprintf(a->error, sizeof a->error, "Embree error %d: %s", (int)code, str ? str : "");
    a->code = code;
    if (!a->building)
        op_log(OP_LOG_ERROR, "%s", a->error);
}

/* Embree's memory monitor: counts its bytes (called from its build threads) and refuses an
 * allocation that would take them over the budget, which Embree reports as out of memory. */
static bool memory_monitor(void *user, ssize_t bytes, bool post)
{
    op_accel *a = user;
    long long now = atomic_fetch_add(&a->bytes, (long long)bytes) + (long long)bytes;
    if (!post && bytes > 0 && now > a->budget) {
        atomic_fetch_sub(&a->bytes, (long long)bytes);
        atomic_store(&a->refused, 1);
        return false;
    }
    return true;
}

/* The address space kept back from Embree's own structures under a limit (ulimit -v), for the
 * small allocations of Embree's task system (TBB) that the memory monitor does not see: with
 * Debian 12's Embree 3, building one sphere needs 6 MiB beyond the device. */
#define ACCEL_RESERVE (16LL << 20)

/* The bytes Embree may take under an address-space limit: what is left of it, less the reserve;
 * negative when not even the reserve is left; LLONG_MAX without a limit. Embree's task system
 * does not survive an allocation that fails inside it (TBB ends the process when it cannot
 * allocate while cancelling a failed build, as when releasing a scene after one), so Embree is
 * refused by its memory monitor while the reserve still holds TBB's own allocations. */
static long long address_space_budget(void)
{
    struct rlimit as;
    if (getrlimit(RLIMIT_AS, &as) != 0 || as.rlim_cur == RLIM_INFINITY)
        return LLONG_MAX;
    long long used = 0;
    FILE *f = fopen("/proc/self/statm", "r");
    if (f) {
        if (fscanf(f, "%lld", &used) != 1)
            used = 0;
        fclose(f);
    }
    long page = sysconf(_SC_PAGESIZE);
    long long left = (long long)as.rlim_cur - used * (page > 0 ? page : 4096);
    return left - ACCEL_RESERVE;
}

/* A triangle geometry over mesh m (shared buffers). */
static RTCGeometry triangles(RTCDevice dev, const op_trimesh *m)
{
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, m->pos, 0,
                               3 * sizeof(float), (size_t)m->nverts);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, m->idx, 0,
                               3 * sizeof(uint32_t), (size_t)m->ntris);
    rtcCommitGeometry(g);
    return g;
}

op_status op_accel_build(const op_accel_shape *shapes, int n, op_accel **out, op_error *err)
{
    op_accel *a = calloc(1, sizeof *a);
    if (!a)
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    atomic_init(&a->bytes, 0);
    a->place = calloc((size_t)(n > 0 ? n : 1), sizeof *a->place);
    /* the distinct instanced meshes: at most n, by their number */
    a->protos = calloc((size_t)(n > 0 ? n : 1), sizeof *a->protos);
    if (!a->place || !a->protos) {
        op_accel_free(a);
        return op_error_set(err, OP_ERR_NOMEM, "out of memory");
    }
    /* Embree's task system (TBB, with Debian 13's Embree 4) ends the process (std::terminate)
     * when it cannot start a worker thread, as under an address-space limit (ulimit -v) each
     * thread's stack may not fit: there it starts none and builds on the calling thread. */
    struct rlimit as;
    int limited = getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY;
    a->device = rtcNewDevice(limited ? "verbose=0,threads=1" : "verbose=0");
    if (!a->device) {
        enum RTCError code = rtcGetDeviceError(NULL);
        op_accel_free(a);
        if (code == RTC_ERROR_OUT_OF_MEMORY)
            return op_error_set(err, OP_ERR_NOMEM, "out of memory (Embree cannot create a device)");
        return op_error_set(err, OP_ERR_INTERNAL, "Embree: cannot create a device (error %d)",
                            (int)code);
    }
    a->budget = address_space_budget();
    if (a->budget < 0) {
        long long left_mib = (a->budget + ACCEL_RESERVE) >> 20;
        op_accel_free(a);
        return op_error_set(err, OP_ERR_NOMEM,
                            "out of memory (%lld MiB of address space left under its limit once "
                            "Embree's device is made; building needs at least %lld)",
                            left_mib, ACCEL_RESERVE >> 20);
    }
    a->building = 1;
    atomic_init(&a->refused, 0);
    rtcSetDeviceErrorFunction(a->device, device_error, a);
    rtcSetDeviceMemoryMonitorFunction(a->device, memory_monitor, a);
    a->scene = rtcNewScene(a->device);
    rtcSetSceneFlags(a->scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(a->scene, RTC_BUILD_QUALITY_HIGH);
    for (int i = 0; i < n; i++) {
        const op_trimesh *m = shapes[i].mesh;
        RTCGeometry g;
        if (shapes[i].place) {
            int k = shapes[i].proto;
            if (k >= a->nprotos)
                a->nprotos = k + 1;
            if (!a->protos[k]) {
                RTCScene ps = rtcNewScene(a->device);
                rtcSetSceneFlags(ps, RTC_SCENE_FLAG_ROBUST);
                rtcSetSceneBuildQuality(ps, RTC_BUILD_QUALITY_HIGH);
                RTCGeometry tg = triangles(a->device, m);
                rtcAttachGeometryByID(ps, tg, 0);
                rtcReleaseGeometry(tg);
                rtcCommitScene(ps);
                a->protos[k] = ps;
            }
            const float *xf = shapes[i].place->m;
            float cm[12]; /* column-major 3 x 4 */
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 4; c++)
                    cm[3 * c + r] = xf[4 * r + c];
            g = rtcNewGeometry(a->device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(g, a->protos[k]);
            rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, cm);
            rtcCommitGeometry(g);
            a->place[i] = shapes[i].place;
        } else {
            g = triangles(a->device, m);
        }
        rtcAttachGeometryByID(a->scene, g, (unsigned)i);
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(a->scene);
    a->building = 0;
    if (a->error[0]) {
        op_status st;
        if (atomic_load(&a->refused))
            st = op_error_set(err, OP_ERR_NOMEM,
                              "out of memory (Embree's structures need more than the %lld MiB "
                              "of address space left to them under its limit)",
                              a->budget >> 20);
        else if (a->code == RTC_ERROR_OUT_OF_MEMORY)
            st = op_error_set(err, OP_ERR_NOMEM, "out of memory (%s)", a->error);
        else
            st = op_error_set(err, OP_ERR_INTERNAL, "%s", a->error);
        op_accel_free(a);
        return st;
    }
    *out = a;
    return OP_OK;
}

long long op_accel_bytes(const op_accel *a)
{
    return atomic_load(&((op_accel *)a)->bytes);
}

void op_accel_free(op_accel *a)
{
    if (!a)
        return;
    if (a->scene)
        rtcReleaseScene(a->scene);
    for (int i = 0; i < a->nprotos; i++)
        if (a->protos[i])
            rtcReleaseScene(a->protos[i]);
    free(a->protos);
    free(a->place);
    if (a->device)
        rtcReleaseDevice(a->device);
    free(a);
}

/* Whether Embree may be given the ray: its ray.valid() asserts that every origin and direction
 * component is at most 1.844e18 in magnitude (so finite) and that tnear and tfar are not NaN. The
 * scene builder keeps positions far inside that; this keeps a stray NaN from aborting. */
static int ray_ok(op_v3 o, op_v3 d, float tmin, float tmax)
{
    const float big = 1e18f;
    return fabsf(o.x) <= big && fabsf(o.y) <= big && fabsf(o.z) <= big && fabsf(d.x) <= big &&
           fabsf(d.y) <= big && fabsf(d.z) <= big && tmin >= 0.0f && !isnan(tmax);
}

int op_accel_intersect(const op_accel *a, op_v3 org, op_v3 dir, float tmin, float tmax,
                       op_ray_hit *hit)
{
    if (!ray_ok(org, dir, tmin, tmax))
        return 0; /* no hit */
    struct RTCRayHit rh;
    rh.ray.org_x = org.x;
    rh.ray.org_y = org.y;
    rh.ray.org_z = org.z;
    rh.ray.dir_x = dir.x;
    rh.ray.dir_y = dir.y;
    rh.ray.dir_z = dir.z;
    rh.ray.tnear = tmin;
    rh.ray.tfar = tmax;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtc_intersect(a->scene, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return 0;
    hit->t = rh.ray.tfar;
    hit->prim = (int)rh.hit.primID;
    hit->b1 = rh.hit.u;
    hit->b2 = rh.hit.v;
    hit->ng = v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
        /* Embree gives an instance's normal in its object space */
        hit->shape = (int)rh.hit.instID[0];
        hit->ng = op_place_normal(a->place[hit->shape], hit->ng);
    } else {
        hit->shape = (int)rh.hit.geomID;
    }
    return 1;
}

int op_accel_occluded(const op_accel *a, op_v3 org, op_v3 dir, float tmin, float tmax)
{
    if (!ray_ok(org, dir, tmin, tmax))
        return 1; /* blocked: no light arrives along a ray that cannot be traced */
    struct RTCRay r;
    r.org_x = org.x;
    r.org_y = org.y;
    r.org_z = org.z;
    r.dir_x = dir.x;
    r.dir_y = dir.y;
    r.dir_z = dir.z;
    r.tnear = tmin;
    r.tfar = tmax;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
    rtc_occluded(a->scene, &r);
    return r.tfar < 0.0f;
}
