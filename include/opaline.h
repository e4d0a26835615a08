/*
 * opaline.h - the base of the opaline library: what every opaline program shares.
 *
 * Error reporting, logging, progress reporting, command-line numbers, NumPy .npy headers,
 * threads, input and crash-safe output files, interruption, checksums and the table of
 * scattering media. The rest of the library has a header per audience: opaline_image.h (image
 * files), opaline_material.h (reading and evaluating materials) and opaline_material_write.h
 * (writing them: the factorizer's).
 *
 * Conventions (of every opaline header)
 *  - Every fallible function returns an op_status and, when it fails, fills the caller's
 *    op_error (which may be NULL) with a message that names the file, line or index at fault.
 *  - Objects are opaque; whoever opens or creates one closes it. Pointers returned by getters
 *    stay valid until the owning object is closed.
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

/* CRC-32 (zlib's) of a buffer, continuing from crc (start with 0). */
uint32_t op_crc32(uint32_t crc, const void *data, size_t n);
/* The CRC-32 of A followed by B, from crc(A), crc(B) and B's length in bytes. */
uint32_t op_crc32_combine(uint32_t crc_a, uint32_t crc_b, uint64_t bytes_b);

/* ---------------------------------------------------------------- command-line numbers */

/* op_parse_numbers' flags: a whole number (decimal digits after an optional sign; else any
 * number strtod reads), and an interval open at lo or at hi. */
enum { OP_NUMBER_WHOLE = 1, OP_NUMBER_ABOVE_LO = 2, OP_NUMBER_BELOW_HI = 4 };

/* The one reader of the numbers given to command-line options: text, the value of option opt,
 * is n comma-separated numbers (1 <= n <= 16), stored in out[0..n). The whole text is read (no
 * blanks, nothing after), every number finite and within [lo, hi] (lo and hi within 2^53 of 0
 * for whole numbers). Otherwise OP_ERR_INPUT "OPT TEXT: need a whole number in [LO, HI]" (or
 * "need N comma-separated numbers in (LO, HI)", as the flags say), or "OPT needs a value" when
 * text is NULL; out is then unchanged. */
op_status op_parse_numbers(const char *opt, const char *text, int n, double lo, double hi,
                           int flags, double *out, op_error *err);
/* op_parse_numbers of one number. */
op_status op_parse_number(const char *opt, const char *text, double lo, double hi, int flags,
                          double *out, op_error *err);

/* ---------------------------------------------------------------- NumPy .npy files */

/* The most leading bytes of a file that op_npy_parse_header reads: the preamble and the
 * largest header it accepts (64 KiB). */
#define OP_NPY_MAX_HEADER (12 + 65536)
/* The most bytes op_npy_write_header writes. */
#define OP_NPY_HEADER_SIZE 256

typedef struct op_npy_header {
    int itemsize;         /* 4 or 8 (float32 or float64) */
    int big_endian;
    int ndim;             /* <= 8 */
    long long shape[8];   /* each >= 0 */
    uint64_t data_offset; /* where the array's bytes start */
} op_npy_header;

/* Parses the header at the start of buf, which holds the file's first n bytes (all of them, or
 * at least OP_NPY_MAX_HEADER): magic, version (1 to 3), and the dict's descr (float32 or
 * float64, any byte order), fortran_order (must be False) and shape. OP_ERR_FORMAT for a file
 * that is no .npy or a malformed header, OP_ERR_INPUT for a valid header opaline does not take;
 * messages start with path. */
op_status op_npy_parse_header(const unsigned char *buf, size_t n, const char *path,
                              op_npy_header *h, op_error *err);
/* Writes into buf (OP_NPY_HEADER_SIZE bytes) the format 1.0 header of a little-endian float32
 * array in C order of shape[0..ndim) (1 <= ndim <= 8, extents >= 0), padded as NumPy pads it
 * (spaces, then a newline, the data starting at a multiple of 64 bytes); returns its length. */
size_t op_npy_write_header(unsigned char *buf, int ndim, const long long *shape);

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
