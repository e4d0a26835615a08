/*
 * opaline.h - the opaline library.
 *
 * Reads, writes and evaluates factored heterogeneous subsurface-scattering materials
 * (".opm" files), and holds the support that every opaline program shares: error reporting,
 * logging, progress reporting, input and crash-safe output files, and image files.
 *
 * Conventions
 *  - Every fallible function returns an op_status and, when it fails, fills the caller's
 *    op_error (which may be NULL) with a message that names the file, line or index at fault.
 *  - Objects are opaque; whoever opens or creates one closes it. Pointers returned by getters
 *    stay valid until the owning object is closed.
 *  - A material is read-only once open and may be evaluated from any number of threads.
 *  - Units: a material's physical size is in centimetres; Rd values are dimensionless (the
 *    fraction of the power entering through one incident pixel that leaves through one exit
 *    pixel). docs/formats.md is the one place that defines them.
 */
#ifndef OPALINE_H
#define OPALINE_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---------------------------------------------------------------- errors */

typedef enum op_status {
    OP_OK = 0,
    OP_ERR_INPUT,    /* bad user input: arguments, scene, dataset values (exit code 2) */
    OP_ERR_FORMAT,   /* a file that is truncated, corrupt, hostile or of the wrong kind */
    OP_ERR_IO,       /* the operating system refused a read or write */
    OP_ERR_NOMEM,    /* an allocation failed */
    OP_ERR_NUMERIC,  /* a computation produced no finite result */
    OP_ERR_CANCELLED,/* the user interrupted the work */
    OP_ERR_INTERNAL  /* a broken invariant: a bug in opaline */
} op_status;

typedef struct op_error {
    op_status status;
    char message[1024];
} op_error;

/* Records status and a printf-style message in err (if err is not NULL); returns status. */
op_status op_error_set(op_error *err, op_status status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* Prepends context ("scene.xml:12: ") to the message already in err; returns err->status. */
op_status op_error_prefix(op_error *err, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* The process exit code for a status: 0 for OP_OK, 2 for input and format errors, 130 for a
 * cancellation, 1 otherwise. */
int op_exit_code(op_status status);
const char *op_status_name(op_status status);

/* ---------------------------------------------------------------- logging */

typedef enum op_log_level { OP_LOG_ERROR, OP_LOG_WARN, OP_LOG_INFO, OP_LOG_DEBUG } op_log_level;

/* Sets the most verbose level printed (default OP_LOG_INFO). Call before starting threads. */
void op_log_set_level(op_log_level level);
op_log_level op_log_get_level(void);
/* Writes one line "opaline: <level>: <message>" to stderr, the message passed through
 * op_text_escape; safe from any thread. */
void op_log(op_log_level level, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* Receives every line op_log writes (after the level filter), the message escaped as printed,
 * without the "opaline: <level>: " prefix; called from the logging thread, so it must be
 * thread-safe and must not call op_log. */
typedef void (*op_log_hook_fn)(void *user, op_log_level level, const char *message);
/* Sets (fn NULL: removes) the hook. Call before starting threads, like op_log_set_level. */
void op_log_set_hook(op_log_hook_fn fn, void *user);
/* Copies src into dst (cap bytes, always NUL-terminated when cap > 0) with every control
 * character, C1 control and invalid UTF-8 byte written as a \xNN escape (tab, newline and
 * carriage return as \t, \n, \r), never cutting an escape or a character, so that text from
 * a file cannot drive the terminal. Returns the length written. */
size_t op_text_escape(char *dst, size_t cap, const char *src);

/* ---------------------------------------------------------------- progress */

/* Called at most a few times per second with the fraction done in [0, 1]. */
typedef void (*op_progress_fn)(void *user, const char *label, double fraction, double eta_seconds);

typedef struct op_progress op_progress;

/* Starts reporting a task of `total` units. With fn NULL the report goes to stderr: a bar with
 * an ETA when stderr is a terminal, plain lines every few seconds otherwise, nothing when the
 * log level is below OP_LOG_INFO. Returns NULL only when out of memory (reporting is then
 * silently off; every other function accepts NULL). */
op_progress *op_progress_begin(const char *label, uint64_t total, op_progress_fn fn, void *user);
/* Adds n finished units; safe from any thread. */
void op_progress_advance(op_progress *p, uint64_t n);
/* Prints the final report and frees p. */
void op_progress_end(op_progress *p);

/* ---------------------------------------------------------------- small shared helpers */

/* SplitMix64 (Steele, Lea and Flood 2014): advances *state by the golden-ratio increment and
 * returns the mixed value; the one deterministic 64-bit generator behind every seeded choice
 * (randomized SVD, K-CTA seeding, dataset layouts and Monte Carlo streams, render streams). */
static inline uint64_t op_splitmix64(uint64_t *state)
{
    uint64_t z = (*state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* SplitMix64 as a hash: a bijective mix of x (op_splitmix64 of the state x). */
static inline uint64_t op_hash64(uint64_t x)
{
    return op_splitmix64(&x);
}

/* Little-endian integers in byte buffers, as every opaline file and stream stores them. */
static inline uint32_t op_get_le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static inline uint64_t op_get_le64(const unsigned char *p)
{
    return (uint64_t)op_get_le32(p) | (uint64_t)op_get_le32(p + 4) << 32;
}

static inline void op_put_le32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

static inline void op_put_le64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}

/* Seconds on the monotonic clock (CLOCK_MONOTONIC) from an arbitrary origin: for durations. */
double op_monotonic_seconds(void);

/* ---------------------------------------------------------------- threads */

/* The one thread pool pattern of every opaline program: fn(user, task, thread) for every task
 * in [0, ntasks) on POSIX threads, tasks handed out in index order from a shared counter,
 * thread in [0, threads used), denormals flushed to zero in the workers. Results must depend on
 * the task index only, never on the thread, so output is the same for any thread count. Stops
 * handing out tasks once *cancel (if not NULL) becomes non-zero and then returns
 * OP_ERR_CANCELLED. nthreads <= 0 means all online cores. */
op_status op_parallel_for(int nthreads, int ntasks, void (*fn)(void *user, int task, int thread),
                          void *user, atomic_int *cancel, op_error *err);
/* The number of threads op_parallel_for starts for nthreads (<= 0: online cores), before
 * limiting them to the number of tasks. */
int op_parallel_threads(int nthreads);

/* For loops that are element-wise (no reduction): the function is also compiled for AVX2 and
 * AVX-512, the variant chosen at load time. Every variant gives the same bits, as C11 mode
 * contracts no a * b + c into a fused multiply-add (-ffp-contract=off). GCC only: clang (the
 * fuzzing build) emits no symbol other files can link for a cloned external function. */
#if defined(__x86_64__) && defined(__has_attribute) && !defined(__clang__)
#if __has_attribute(target_clones)
#define OP_VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#endif
#endif
#ifndef OP_VECTOR_CLONES
#define OP_VECTOR_CLONES
#endif

/* ---------------------------------------------------------------- output files */

/* An output file that appears whole or not at all (docs/limits.md, "Output files").
 * op_output_open writes to a temporary file "<dest>.tmp-opaline-<pid>-XXXXXX" beside the file
 * it replaces, symbolic links followed (a link stays a link; its target is replaced, or created
 * when missing), except a link in a sticky world-writable folder that belongs to neither the
 * caller nor the folder's owner (refused, OP_ERR_IO, as the kernel's protected_symlinks rule
 * would). Commit renames it over that file, which keeps its permission bits, extended
 * attributes (ACLs) and, when run as root, its owner; a new file gets 0666 less the umask. A
 * destination that is a character device (/dev/null), a FIFO or a descriptor (/dev/stdout,
 * /dev/fd/N), or a file whose attributes cannot be given to a new file, is never replaced: the
 * data waits in $TMPDIR (default /tmp) or beside it and commit copies it through. Directories,
 * block devices and sockets are refused (OP_ERR_IO). An output that is an input of this run
 * (op_file_protect_inputs) or the same file as another output still open is refused
 * (OP_ERR_INPUT). Opening also removes the temporary files for the same destination that no
 * writer holds locked (left after SIGKILL), never one of a live writer, whatever pid namespace
 * it runs in. All functions are thread-safe for distinct objects. */
typedef struct op_output op_output;

op_status op_output_open(const char *path, op_output **out, op_error *err);
/* op_output_open for a file that is meant to be both an input and an output of this run (a
 * cache brought up to date): it may replace an input. */
op_status op_output_open_update(const char *path, op_output **out, op_error *err);
/* Checks, before any work, that each of outputs[0..n) can be written (op_output_open accepts
 * it: its folder exists and takes a new file, its type, its links), that no two of them are the
 * same file (device and inode, links followed; for a file yet to be made, the same name in the
 * same folder) and that none is one of inputs[0..m) (NULL entries skipped) or an input of this
 * run. Leaves nothing behind. */
op_status op_output_check(const char *const *outputs, int n, const char *const *inputs, int m,
                          op_error *err);
/* The stream to write to (seekable: it is always the temporary file). */
FILE *op_output_stream(op_output *out);
/* Writes n bytes; the first failure is remembered and reported by commit. */
void op_output_write(op_output *out, const void *data, size_t n);
/* Flushes what was written so far and gives the temporary file's name in *tmp_path, for reading
 * it back (e.g. to verify it) before commit or abort; the name is valid until then. Fails with
 * the first write error. */
op_status op_output_pending(op_output *out, const char **tmp_path, op_error *err);
/* Flushes, syncs and puts the file in place; frees out whatever the result. */
op_status op_output_commit(op_output *out, op_error *err);
/* Removes the temporary file and frees out. Accepts NULL. */
void op_output_abort(op_output *out);
/* Outputs put in place all together or not at all. After op_output_group_begin, an
 * op_output_commit on the calling thread only completes the output (written, flushed, synced;
 * every write error reported then) and keeps it pending; op_output_group_commit puts all the
 * pending ones in place, those written through to a device or FIFO first, then the renames
 * (at the first failure the rest are removed, so a device that refuses its data leaves every
 * file as it was); op_output_group_abort removes them all. Either ends the group. */
void op_output_group_begin(void);
op_status op_output_group_commit(op_error *err);
void op_output_group_abort(void);

/* ---------------------------------------------------------------- interruption */

/* Called, from a thread of its own, on the first SIGINT, SIGTERM or SIGHUP. */
typedef void (*op_interrupt_fn)(void *user, int signo);

/* Makes SIGINT, SIGTERM and SIGHUP interrupt the process cleanly, and ignores SIGPIPE and
 * SIGXFSZ (a closed pipe, a file over `ulimit -f`, is then a write error, EPIPE or EFBIG, that
 * reaches the exit code like any other). With fn NULL, a
 * signal removes the temporary file of every op_output not yet committed or aborted, logs
 * "interrupted by SIGxxx" and exits with 130 at once, from any point of the work (it waits only
 * for a commit's rename in progress). With fn, the first signal calls fn (cooperative
 * cancellation: the program stops, aborts its outputs and exits 130 itself) and a second one
 * does the above. A signal ignored when the process started (nohup) stays ignored. Call once,
 * from main, before starting threads. */
op_status op_interrupt_install(op_interrupt_fn fn, void *user, op_error *err);

/* ---------------------------------------------------------------- input files */

/* Every reader of an input file opens it through these, so that every program refuses the
 * same things with the same words: a missing file is OP_ERR_INPUT "PATH: no such file"; a
 * directory, FIFO, socket or device is OP_ERR_INPUT "PATH: is a directory, not a file" (and
 * the like), at once, without ever blocking on a FIFO; an unreadable one OP_ERR_INPUT
 * "PATH: permission denied". */

/* From now on every file opened through these is remembered as an input of this run, and
 * op_output_open refuses to replace it: programs call it first thing in main, so that no output
 * of a run destroys one of its inputs (through links, hard links or another spelling). */
void op_file_protect_inputs(void);
/* Calls fn with the path (as first opened) of every input remembered so far, in the order
 * first opened (how opaline-render lists the files a scene reads). fn must open no file. */
void op_file_inputs_each(void (*fn)(void *user, const char *path), void *user);

/* Opens a regular file for reading (blocking, close-on-exec); *size (if not NULL) is its size
 * in bytes when opened. */
op_status op_file_open(const char *path, int *fd, uint64_t *size, op_error *err);
/* op_file_open as a stdio stream, positioned at the start. */
op_status op_file_open_stream(const char *path, FILE **f, uint64_t *size, op_error *err);
/* Reads the whole file into a malloc'ed buffer (*data, with a NUL byte after the *size bytes
 * read); a file over max_bytes is OP_ERR_INPUT naming the limit. */
op_status op_file_read(const char *path, size_t max_bytes, char **data, size_t *size,
                       op_error *err);

/* A read-only view of a whole input file: mapped, or read into memory when it cannot be. */
typedef struct op_file_view {
    const void *data; /* size bytes; NULL when size is 0 */
    size_t size;
    int slot;         /* internal: the fault-table slot, or -1 when data was read into memory */
} op_file_view;

/* Maps the file read-only. While it is mapped, a fault on it (the file truncated or replaced
 * in place by another program) ends the process with exit code 2 and the message
 * "PATH: the file was truncated or changed while in use", once op_file_guard_faults has run. */
op_status op_file_map(const char *path, op_file_view *map, op_error *err);
/* Drops the whole pages within [p, p + n) of a mapped view from the process's memory: they are
 * read again from the file (or the page cache) when next touched. For reading a file larger
 * than memory in passes with a bounded resident size. Does nothing for a view read into memory
 * or for a range outside the view. */
void op_file_release(const op_file_view *map, const void *p, size_t n);
/* Unmaps (or frees) and zeroes map. Accepts a zeroed map. */
void op_file_unmap(op_file_view *map);
/* Installs the SIGBUS handler behind op_file_map's promise; other faults keep their default
 * action. Programs call it once, first thing in main(); calling it again does nothing. */
void op_file_guard_faults(void);

/* ---------------------------------------------------------------- images */

/* Pixels are linear-light floats, row-major from the top row, `channels` interleaved per pixel
 * (1 = grey, 3 = RGB, 4 = RGBA). */
typedef struct op_image {
    int width, height, channels;
    float *pixels;
} op_image;

/* The largest image opaline holds: each side at most OP_IMAGE_MAX_SIDE, width x height at most
 * OP_IMAGE_MAX_PIXELS (far above any render, far below overflow). A scene's film is refused
 * beyond them when it loads. */
#define OP_IMAGE_MAX_SIDE 65536
#define OP_IMAGE_MAX_PIXELS ((size_t)1 << 30)

/* A zeroed image; a size beyond the limits above or a channel count not 1, 3 or 4 is
 * OP_ERR_INPUT. */
op_status op_image_alloc(op_image *img, int width, int height, int channels, op_error *err);
void op_image_free(op_image *img);
/* 8-bit sRGB PNG after multiplying by 2^exposure_stops; values are clamped to [0, 1]. */
op_status op_image_write_png(const char *path, const op_image *img, float exposure_stops,
                             op_error *err);
/* OpenEXR (via its C API), half floats when half_float != 0, else 32-bit floats. */
op_status op_image_write_exr(const char *path, const op_image *img, int half_float, op_error *err);
/* op_image_write_exr with one more header attribute, the string attr_name = attr_value. */
op_status op_image_write_exr_attr(const char *path, const op_image *img, int half_float,
                                  const char *attr_name, const char *attr_value, op_error *err);
/* The string attribute name of an OpenEXR file's first part into out (n bytes, truncated),
 * "" when it has none; OP_ERR_FORMAT when path is not a readable OpenEXR file. */
op_status op_image_exr_attr(const char *path, const char *name, char *out, size_t n,
                            op_error *err);
/* Portable float map, little-endian. */
op_status op_image_write_pfm(const char *path, const op_image *img, op_error *err);
/* Radiance RGBE (.hdr): shared-exponent RGB, 4 bytes a pixel (a grey image repeats its
 * channel, alpha is dropped). */
op_status op_image_write_hdr(const char *path, const op_image *img, op_error *err);
/* Reads an OpenEXR, PNG or PFM file (chosen by content) into linear floats. */
op_status op_image_read(const char *path, op_image *img, op_error *err);
/* The same, but 8-bit files (PNG) keep their stored values (byte / 255) instead of being
 * sRGB-decoded, so that a caller can apply another transfer curve; *encoded is set to 1 for
 * those and to 0 for float files (OpenEXR, PFM), whose values both functions return as stored. */
op_status op_image_read_stored(const char *path, op_image *img, int *encoded, op_error *err);
/* The most pixels (width x height) the two readers above accept: 2^27 (16384 x 8192). */
#define OP_IMAGE_DEFAULT_MAX_PIXELS ((uint64_t)1 << 27)
/* op_image_read (decode != 0) or op_image_read_stored (decode == 0; encoded may be NULL) with
 * another pixel limit: an image whose header says it has more than max_pixels pixels is refused
 * (OP_ERR_INPUT naming the limit "image-pixels") before anything is decoded or allocated. */
op_status op_image_read_limited(const char *path, int decode, uint64_t max_pixels, op_image *img,
                                int *encoded, op_error *err);

/* ---------------------------------------------------------------- materials */

typedef enum op_method {
    OP_METHOD_RAW = 0, /* the dataset itself: the reference */
    OP_METHOD_SVD,     /* log-transformed truncated SVD per channel (Onel, Kurt, Ozturk) */
    OP_METHOD_TUCKER,  /* Tucker of the channel mean + per-row polynomial colour regression */
    OP_METHOD_KCTA,    /* K-clustered tensor approximation (Tsai and Shih 2012) */
    OP_METHOD_NMF,     /* non-negative matrix factorization baseline (Peers et al. 2006) */
    OP_METHOD_COUNT
} op_method;

const char *op_method_name(op_method m);
/* Returns OP_METHOD_COUNT for an unknown name. */
op_method op_method_from_name(const char *name);

/* What a material is. Rows are incident pixels (row index y * width + x), columns are kernel
 * offsets (column index (dy + kernel/2) * kernel + (dx + kernel/2)). */
typedef struct op_material_info {
    op_method method;
    int width, height;         /* incident pixels */
    int kernel;                /* odd kernel side K: offsets range over [-K/2, K/2] */
    int channels;              /* 1 or 3 (R, G, B) */
    double size_x_cm, size_y_cm; /* physical size of the sample */
    int terms;                 /* T (svd, tucker, kcta, nmf), 0 for raw */
    int degree;                /* P (tucker), 0 otherwise */
    int clusters;              /* C (kcta), 0 otherwise */
    int shifted;               /* rows were shifted and normalized (paper section 4.1) */
    double log_a, log_b;       /* svd: R''' = ln(R'/A + B) */
    uint32_t dataset_crc;      /* CRC-32 of the source dataset's Rd values */
    char name[128];            /* e.g. "Chess4x4" */
    char generator[128];       /* how the source data was made, free text */
    char tool_version[32];
} op_material_info;

typedef struct op_material op_material;

/* Opens and fully validates a material file (header, section table, checksums, dimensions,
 * method-specific invariants). A truncated, corrupt or hostile file gives OP_ERR_FORMAT. */
op_status op_material_open(const char *path, op_material **out, op_error *err);
void op_material_close(op_material *m);
const op_material_info *op_material_get_info(const op_material *m);
/* Bytes the material occupies on disk. */
uint64_t op_material_file_size(const op_material *m);

/* Rd for `channel` at incident pixel (x, y) and offset (dx, dy); 0 outside the kernel.
 * Coordinates must be in range (checked only by assertions). Never negative or NaN. */
float op_material_eval(const op_material *m, int channel, int x, int y, int dx, int dy);
/* The whole kernel row of incident pixel (x, y): K*K values in column order. */
void op_material_eval_row(const op_material *m, int channel, int x, int y, float *out);
/* Albedo map: for every channel and incident pixel the row sum, as channels*width*height
 * floats, channel-major. */
op_status op_material_albedo_map(const op_material *m, float *out, op_error *err);

/* A named section's bytes (e.g. "RD.R" of a raw material), or NULL when absent. Sections are
 * aligned to 64 bytes in the file and in memory. */
const void *op_material_section(const op_material *m, const char *tag, uint64_t *bytes);
/* The checksum stored for a section (verified when the file was opened), or 0 when absent. */
uint32_t op_material_section_crc(const op_material *m, const char *tag);
/* The tag of a per-channel section: prefix + "R"/"G"/"B", or + "Y" for one channel. */
void op_channel_tag(char *tag, size_t n, const char *prefix, const op_material_info *info, int c);
/* Rows (incident pixels, width * height) and columns (kernel offsets, K * K) of a material. */
int64_t op_material_rows(const op_material *m);
int op_material_cols(const op_material *m);

/* Opens a file's container and META only (header, section table, checksums, dimensions) without
 * the method's checks: sections may be read with op_material_section, but eval, eval_row and
 * albedo must not be called. The factorizer reads datasets this way, so that NaN or negative
 * noise in a dataset gets its own clear report. Close with op_material_close. */
op_status op_material_open_container(const char *path, op_material **out, op_error *err);
/* op_material_open_container for a file larger than memory, read in passes: each section's
 * pages are dropped from memory once its checksum is verified (in pieces, so the resident size
 * stays bounded), and readers drop the rows they are done with by op_material_release. */
op_status op_material_open_streaming(const char *path, op_material **out, op_error *err);
/* op_file_release on m's file: [p, p + n) lies within one of its sections. */
void op_material_release(const op_material *m, const void *p, size_t n);

/* Writing: open, add each section once, commit. Section tags are 1 to 8 printable characters;
 * "META" is written by the library from info. The file is an op_output: it appears whole at
 * path on commit, or not at all. */
typedef struct op_material_writer op_material_writer;

op_status op_material_writer_open(const char *path, const op_material_info *info,
                                  op_material_writer **out, op_error *err);
op_status op_material_writer_add(op_material_writer *w, const char *tag, const void *data,
                                 uint64_t bytes, op_error *err);
/* A section written in pieces: reserve gives it its place and size (the sections after it go
 * beyond), fill appends its next n bytes (its checksum follows along), in any interleaving with
 * other reserved sections; commit refuses a section not filled to its size. */
op_status op_material_writer_reserve(op_material_writer *w, const char *tag, uint64_t bytes,
                                     op_error *err);
op_status op_material_writer_fill(op_material_writer *w, const char *tag, const void *data,
                                  size_t n, op_error *err);
/* Rewrites META from info, which must give text of the same length (fixed-width fields such as
 * dataset_crc may change: a checksum known only once the data is written). */
op_status op_material_writer_set_info(op_material_writer *w, const op_material_info *info,
                                      op_error *err);
/* Completes the file under its temporary name (section table and header) without putting it in
 * place, and gives that name in *tmp_path, valid until commit or abort: the file can be read
 * back with op_material_open to verify it. Sections may still be added after. */
op_status op_material_writer_finish(op_material_writer *w, const char **tmp_path, op_error *err);
/* Writes the section table and puts the file in place; frees w whatever the result. */
op_status op_material_writer_commit(op_material_writer *w, op_error *err);
/* Removes the temporary file and frees w. Accepts NULL. */
void op_material_writer_abort(op_material_writer *w);

/* Each method's section layout has one home, libopaline/method_<name>.c, which writes the
 * sections (these functions) and reads them back (op_material_open); docs/formats.md is the
 * specification. info is the META w was opened with; every array holds the count info implies
 * (rows = width * height, n = kernel * kernel, T = terms, C = clusters), row-major. shift (rows
 * u32) and max (rows float32) are each row's shift and maximum, required exactly when
 * info->shifted. Call them in the order given for a method: the file's layout follows it. */
/* The prefix of a raw material's (a dataset's) per-channel Rd sections (op_channel_tag). */
#define OP_RAW_SECTION "RD."
/* raw: channel c's Rd values, rows x n. */
op_status op_write_raw_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *rd, op_error *err);
/* svd: channel c's U (rows x T, scaled by the singular values) and V (n x T). */
op_status op_write_svd_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *u, const float *v, const uint32_t *shift,
                               const float *max, op_error *err);
/* tucker: U (rows x T), V (n x T), RANGE (rows x 2), BETA (channels x rows x (degree + 1)). */
op_status op_write_tucker(op_material_writer *w, const op_material_info *info, const float *u,
                          const float *v, const float *range, const float *beta,
                          const uint32_t *shift, const float *max, op_error *err);
/* kcta, per channel: BASIS (C x n x T), KIDX (rows x km indices of index_bytes, 2 or 4, each),
 * KCOEF (rows x km x T); after the channels op_write_kcta_params. */
op_status op_write_kcta_channel(op_material_writer *w, const op_material_info *info, int c,
                                int km, int index_bytes, const float *basis, const void *idx,
                                const float *coef, const uint32_t *shift, const float *max,
                                op_error *err);
op_status op_write_kcta_params(op_material_writer *w, int km, int index_bytes, op_error *err);
/* nmf: channel c's PROF (n), SCALE (rows), W (rows x T) and H (n x T). */
op_status op_write_nmf_channel(op_material_writer *w, const op_material_info *info, int c,
                               const float *prof, const float *scale, const float *wf,
                               const float *h, op_error *err);
/* Any factored method, last: the row sums of the reconstruction (channels x rows), which
 * op_material_albedo_map then copies. */
op_status op_write_albedo(op_material_writer *w, const op_material_info *info,
                          const float *albedo, op_error *err);

/* CRC-32 (zlib's) of a buffer, continuing from crc (start with 0). */
uint32_t op_crc32(uint32_t crc, const void *data, size_t n);
/* The CRC-32 of A followed by B, from crc(A), crc(B) and B's length in bytes. */
uint32_t op_crc32_combine(uint32_t crc_a, uint32_t crc_b, uint64_t bytes_b);

/* ---------------------------------------------------------------- scattering media */
/* The one table of named scattering media, shared by the dataset generator and the renderer's
 * dipole (libopaline/media.c; sources in docs/datasets.md). Coefficients are the reduced
 * scattering sigma_s' and absorption sigma_a per R, G, B in 1/mm (phase function g = 0 after
 * reduction); eta is the medium's index of refraction relative to the outside (air). */
typedef struct op_medium {
    const char *name;  /* canonical spelling, e.g. "Marble" */
    double sigma_s[3]; /* reduced scattering coefficient, 1/mm */
    double sigma_a[3]; /* absorption coefficient, 1/mm */
    double eta;        /* relative index of refraction, > 1 */
    const char *source; /* where the values come from */
} op_medium;

/* The medium called `name` (case-insensitive), or NULL when there is none (or name is NULL). */
const op_medium *op_medium_lookup(const char *name);
/* The i-th medium of the table (0 <= i < op_medium_count()), else NULL. */
const op_medium *op_medium_at(int i);
int op_medium_count(void);
/* The media's names, ", "-separated, in table order (for messages; a static string). */
const char *op_medium_names(void);

const char *op_version(void);

#ifdef __cplusplus
}
#endif
#endif
