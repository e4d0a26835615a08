/* file.c - the one way opaline opens an input file: its type checked before anything is
 * read, whole-file reads with a size limit, and read-only mappings whose faults (the file
 * truncated while mapped) end the process with a message instead of a bare SIGBUS.
 *
 * Mapped ranges are kept in a fixed table that the SIGBUS handler reads: each slot is claimed
 * with a compare-and-swap, filled, then published by one atomic store, so the handler (which
 * takes no lock and calls only async-signal-safe functions) never sees a half-written slot. */
#include "opaline.h"
#include "file_inputs.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

/* ------------------------------------------------------------ this run's inputs */

typedef struct run_input {
    dev_t dev;
    ino_t ino;
    char *path; /* as first opened */
} run_input;

static pthread_mutex_t inputs_lock = PTHREAD_MUTEX_INITIALIZER;
static int inputs_protected;
static run_input *inputs;
static size_t inputs_n, inputs_cap;

void op_file_protect_inputs(void)
{
    pthread_mutex_lock(&inputs_lock);
    inputs_protected = 1;
    pthread_mutex_unlock(&inputs_lock);
}

/* Remembers the file sb describes as an input of this run; a failed allocation only loses the
 * protection of this one file. */
static void remember_input(const char *path, const struct stat *sb)
{
    pthread_mutex_lock(&inputs_lock);
    int known = !inputs_protected;
    for (size_t i = 0; i < inputs_n && !known; i++)
        known = inputs[i].dev == sb->st_dev && inputs[i].ino == sb->st_ino;
    if (!known && inputs_n == inputs_cap) {
        size_t cap = inputs_cap ? 2 * inputs_cap : 16;
        run_input *grown = realloc(inputs, cap * sizeof *grown);
        if (grown) {
            inputs = grown;
            inputs_cap = cap;
        }
    }
    if (!known && inputs_n < inputs_cap && (inputs[inputs_n].path = strdup(path))) {
        inputs[inputs_n].dev = sb->st_dev;
        inputs[inputs_n].ino = sb->st_ino;
        inputs_n++;
    }
    pthread_mutex_unlock(&inputs_lock);
}

void op_file_inputs_each(void (*fn)(void *user, const char *path), void *user)
{
    pthread_mutex_lock(&inputs_lock);
    for (size_t i = 0; i < inputs_n; i++)
        fn(user, inputs[i].path);
    pthread_mutex_unlock(&inputs_lock);
}

int op_file_input_path(dev_t dev, ino_t ino, char *path, size_t n)
{
    int found = 0;
    pthread_mutex_lock(&inputs_lock);
    for (size_t i = 0; i < inputs_n && !found; i++)
        if (inputs[i].dev == dev && inputs[i].ino == ino) {
            snprintf(path, n, "%s", inputs[i].path);
            found = 1;
        }
    pthread_mutex_unlock(&inputs_lock);
    return found;
}

/* ------------------------------------------------------------ opening */


static op_status refuse_type(const char *path, mode_t mode, op_error *err)
{
    const char *what = S_ISDIR(mode)    ? "a directory"
                       : S_ISFIFO(mode) ? "a FIFO (named pipe)"
                       : S_ISSOCK(mode) ? "a socket"
                       : S_ISCHR(mode)  ? "a character device"
                       : S_ISBLK(mode)  ? "a block device"
                                        : "a special file";
    return op_error_set(err, OP_ERR_INPUT, "%s: is %s, not a file", path, what);
}

static op_status refuse_errno(const char *path, int e, op_error *err)
{
    switch (e) {
    case ENOENT:
    case ENOTDIR:
        return op_error_set(err, OP_ERR_INPUT, "%s: no such file", path);
    case EACCES:
    case EPERM:
        return op_error_set(err, OP_ERR_INPUT, "%s: permission denied", path);
    case ELOOP:
        return op_error_set(err, OP_ERR_INPUT, "%s: too many levels of symbolic links", path);
    case ENAMETOOLONG:
        return op_error_set(err, OP_ERR_INPUT, "%s: the file name is too long", path);
    case ENOMEM:
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    default:
        return op_error_set(err, OP_ERR_IO, "%s: cannot open: %s", path, strerror(e));
    }
}

op_status op_file_open(const char *path, int *fd, uint64_t *size, op_error *err)
{
    *fd = -1;
    struct stat sb;
    /* stat first, so that a device or FIFO is refused without being opened at all. */
    if (stat(path, &sb) != 0)
        return refuse_errno(path, errno, err);
    if (!S_ISREG(sb.st_mode))
        return refuse_type(path, sb.st_mode, err);
    /* O_NONBLOCK: if the path became a FIFO since stat, open must not wait for a writer. */
    int d = open(path, O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
    if (d < 0)
        return refuse_errno(path, errno, err);
    if (fstat(d, &sb) != 0) {
        int e = errno;
        close(d);
        return op_error_set(err, OP_ERR_IO, "%s: cannot read: %s", path, strerror(e));
    }
    if (!S_ISREG(sb.st_mode)) {
        close(d);
        return refuse_type(path, sb.st_mode, err);
    }
    int flags = fcntl(d, F_GETFL);
    if (flags < 0 || fcntl(d, F_SETFL, flags & ~O_NONBLOCK) != 0) {
        int e = errno;
        close(d);
        return op_error_set(err, OP_ERR_IO, "%s: cannot read: %s", path, strerror(e));
    }
    remember_input(path, &sb);
    *fd = d;
    if (size)
        *size = (uint64_t)sb.st_size;
    return OP_OK;
}

op_status op_file_open_stream(const char *path, FILE **f, uint64_t *size, op_error *err)
{
    *f = NULL;
    int fd;
    op_status st = op_file_open(path, &fd, size, err);
    if (st != OP_OK)
        return st;
    *f = fdopen(fd, "rb");
    if (!*f) {
        close(fd);
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
    }
    return OP_OK;
}

/* Reads from fd until end of file or until more than max bytes have come; *data gets a NUL
 * byte after the last. */
static op_status read_all(const char *path, int fd, uint64_t hint, size_t max, char **data,
                          size_t *size, op_error *err)
{
    size_t cap = (hint < max ? (size_t)hint : max) + 1, n = 0;
    char *buf = malloc(cap + 1);
    if (!buf)
        return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory for %zu bytes", path, cap);
    for (;;) {
        if (n == cap) { /* the file grew since fstat, or max was reached */
            if (n > max)
                break;
            size_t grown = cap > max / 2 ? max + 1 : 2 * cap;
            char *b = realloc(buf, grown + 1);
            if (!b) {
                free(buf);
                return op_error_set(err, OP_ERR_NOMEM, "%s: out of memory", path);
            }
            buf = b;
            cap = grown;
        }
        ssize_t r = read(fd, buf + n, cap - n);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            int e = errno;
            free(buf);
            return op_error_set(err, OP_ERR_IO, "%s: cannot read: %s", path, strerror(e));
        }
        if (r == 0)
            break;
        n += (size_t)r;
    }
    if (n > max) {
        free(buf);
        return op_error_set(err, OP_ERR_INPUT, "%s: the file is larger than the limit of %zu "
                            "bytes for it", path, max);
    }
    buf[n] = '\0';
    *data = buf;
    *size = n;
    return OP_OK;
}

op_status op_file_read(const char *path, size_t max_bytes, char **data, size_t *size,
                       op_error *err)
{
    *data = NULL;
    *size = 0;
    int fd;
    uint64_t bytes = 0; /* set by op_file_open on success (initialized for gcc 14) */
    op_status st = op_file_open(path, &fd, &bytes, err);
    if (st != OP_OK)
        return st;
    if (bytes > max_bytes) {
        close(fd);
        return op_error_set(err, OP_ERR_INPUT, "%s: the file is %llu bytes, larger than the "
                            "limit of %zu bytes for it", path, (unsigned long long)bytes,
                            max_bytes);
    }
    st = read_all(path, fd, bytes, max_bytes, data, size, err);
    close(fd);
    return st;
}

/* ------------------------------------------------------------ the mapped-range table */

enum { SLOT_FREE, SLOT_BUSY, SLOT_LIVE, MAX_SLOTS = 256, SLOT_MESSAGE = 480 };

typedef struct map_slot {
    atomic_int state;
    _Atomic uintptr_t start, length; /* whole pages */
    char message[SLOT_MESSAGE];      /* the complete line the handler writes */
    size_t message_len;
} map_slot;

static map_slot slots[MAX_SLOTS];

/* Claims a slot for [start, start + length) and publishes it; -1 when the table is full. */
static int register_range(const char *path, const void *start, size_t length)
{
    for (int i = 0; i < MAX_SLOTS; i++) {
        int expected = SLOT_FREE;
        if (!atomic_compare_exchange_strong(&slots[i].state, &expected, SLOT_BUSY))
            continue;
        map_slot *s = &slots[i];
        static const char head[] = "opaline: error: ",
                          tail[] = ": the file was truncated or changed while in use\n";
        char name[SLOT_MESSAGE - sizeof head - sizeof tail];
        op_text_escape(name, sizeof name, path);
        s->message_len = (size_t)snprintf(s->message, sizeof s->message, "%s%s%s", head, name,
                                          tail);
        atomic_store(&s->start, (uintptr_t)start);
        atomic_store(&s->length, (uintptr_t)length);
        atomic_store(&s->state, SLOT_LIVE);
        return i;
    }
    return -1;
}

static void on_sigbus(int sig, siginfo_t *info, void *context)
{
    (void)context;
    uintptr_t a = (uintptr_t)info->si_addr;
    for (int i = 0; info->si_code > 0 && i < MAX_SLOTS; i++) {
        const map_slot *s = &slots[i];
        if (atomic_load(&s->state) == SLOT_LIVE &&
            a - atomic_load(&s->start) < atomic_load(&s->length)) {
            /* One message however many threads fault: the others wait for the exit. */
            static atomic_int reported;
            if (atomic_exchange(&reported, 1))
                for (;;)
                    pause();
            ssize_t w = write(STDERR_FILENO, s->message, s->message_len);
            (void)w;
            _exit(2);
        }
    }
    /* Not ours: the default action, as if no handler had been installed. */
    struct sigaction dfl;
    memset(&dfl, 0, sizeof dfl);
    dfl.sa_handler = SIG_DFL;
    sigemptyset(&dfl.sa_mask);
    sigaction(sig, &dfl, NULL);
    raise(sig);
}

void op_file_guard_faults(void)
{
    static atomic_int installed;
    if (atomic_exchange(&installed, 1))
        return;
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_sigaction = on_sigbus;
    sa.sa_flags = SA_SIGINFO;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGBUS, &sa, NULL);
}

/* ------------------------------------------------------------ mapping */

op_status op_file_map(const char *path, op_file_view *map, op_error *err)
{
    map->data = NULL;
    map->size = 0;
    map->slot = -1;
    int fd;
    uint64_t size;
    op_status st = op_file_open(path, &fd, &size, err);
    if (st != OP_OK)
        return st;
    if (size > (uint64_t)SIZE_MAX / 2) {
        close(fd);
        return op_error_set(err, OP_ERR_INPUT, "%s: the file is too large to read", path);
    }
    if (size == 0) {
        close(fd);
        return OP_OK;
    }
    long page = sysconf(_SC_PAGESIZE);
    size_t pages = ((size_t)size + (size_t)page - 1) / (size_t)page * (size_t)page;
    void *p = mmap(NULL, (size_t)size, PROT_READ, MAP_PRIVATE, fd, 0);
    int slot = p == MAP_FAILED ? -1 : register_range(path, p, pages);
    if (slot >= 0) {
        close(fd);
        map->data = p;
        map->size = (size_t)size;
        map->slot = slot;
        return OP_OK;
    }
    /* No mapping, or no room to guard it: read the file instead, which no truncation can
     * turn into a fault. */
    if (p != MAP_FAILED)
        munmap(p, (size_t)size);
    char *data;
    size_t n;
    st = read_all(path, fd, size, SIZE_MAX / 2, &data, &n, err);
    close(fd);
    if (st == OP_OK && n != size) {
        free(data);
        st = op_error_set(err, OP_ERR_INPUT, "%s: the file was truncated or changed while in "
                          "use", path);
    }
    if (st == OP_OK) {
        map->data = data;
        map->size = n;
    }
    return st;
}

void op_file_release(const op_file_view *map, const void *p, size_t n)
{
    const char *lo = map->data, *hi = lo ? lo + map->size : lo, *a = p, *b = a + n;
    if (!lo || map->slot < 0 || a < lo || b > hi || a >= b)
        return;
    uintptr_t page = (uintptr_t)sysconf(_SC_PAGESIZE);
    uintptr_t first = ((uintptr_t)a + page - 1) / page * page, last = (uintptr_t)b / page * page;
    if (b == hi) /* the file's last page, partial or not, belongs to the range */
        last = ((uintptr_t)b + page - 1) / page * page;
    if (last > first)
        madvise((void *)first, last - first, MADV_DONTNEED); /* advisory: pages of a read-only
                                                                 private file mapping, clean */
}

void op_file_unmap(op_file_view *map)
{
    if (map->data && map->slot >= 0) {
        map_slot *s = &slots[map->slot];
        atomic_store(&s->state, SLOT_BUSY);
        munmap((void *)map->data, map->size);
        atomic_store(&s->state, SLOT_FREE);
    } else {
        free((void *)map->data);
    }
    map->data = NULL;
    map->size = 0;
    map->slot = -1;
}
