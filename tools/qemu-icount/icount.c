/*
 * icount.c - QEMU TCG plugin: instructions executed between two marker functions.
 *
 *   qemu-system-arm ... -plugin libqemu-icount.so,begin=0xADDR,end=0xADDR[,out=FILE][,profile=FILE]
 *                   [,verbose=on]
 *                   -d plugin [-D logfile]
 *
 * `begin` and `end` are the entry addresses of two functions (e.g. caekf_mark_begin and
 * caekf_mark_end from `arm-none-eabi-nm image.elf`; the Thumb bit is ignored). An interval runs
 * from entering `begin` to entering `end`: it counts the instructions of `begin` itself and of
 * everything executed until `end` is entered (not `end`'s own). The images call begin/end around
 * each estimator step, so each interval is one step.
 *
 * How: every translation block gets an inline "counter += number of instructions" op, except the
 * blocks starting at a marker address, which get a callback that snapshots the counter (and then
 * adds their own instructions). A function entered by a call always starts a translation block, so
 * this is exact per executed instruction and independent of timing: the same image gives the same
 * counts run after run. Instructions of a block are all counted when the block starts, so a fault
 * in the middle of a block would over-count; the measured code does not fault.
 *
 * Output (qemu_plugin_outs, visible with `-d plugin`): with verbose=on one line per interval,
 * and at exit one summary line:
 *   icount: intervals=N min=.. median=.. max=.. mean=.. argmax=K total=..
 * out=FILE writes every interval's count, one per line, in order.
 * profile=FILE writes "vaddr n_insns executions" per translation block start address, over the
 * whole run (not only inside intervals), for a per-function profile (icount-run.py --profile).
 * profile_interval=K restricts that profile to interval K (0-based): the breakdown of one step,
 * e.g. the worst one (icount-run.py --profile-interval).
 *
 * QEMU 7.2 as packaged by Debian ships no qemu-plugin.h, so the subset of the plugin API v1 used
 * here is declared below (same declarations as QEMU's include/qemu/qemu-plugin.h, API version 1).
 */
#include <inttypes.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- QEMU plugin API v1 (subset) ---------------------------------------------------------------- */
#define QEMU_PLUGIN_EXPORT __attribute__((visibility("default")))

typedef uint64_t qemu_plugin_id_t;

typedef struct qemu_info_t {
    const char *target_name;
    struct {
        int min;
        int cur;
    } version;
    bool system_emulation;
    union {
        struct {
            int smp_vcpus;
            int max_vcpus;
        } system;
    };
} qemu_info_t;

struct qemu_plugin_tb;
struct qemu_plugin_insn;

enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };

typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, qemu_plugin_vcpu_udata_cb_t cb,
                                          enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                              void *ptr, uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
void qemu_plugin_outs(const char *string);

QEMU_PLUGIN_EXPORT extern int qemu_plugin_version;
QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc,
                                           char **argv);
/* ------------------------------------------------------------------------------------------------- */

QEMU_PLUGIN_EXPORT int qemu_plugin_version = 1;

static uint64_t addr_begin = UINT64_MAX;
static uint64_t addr_end = UINT64_MAX;
static bool verbose;
static const char *out_path;

static uint64_t counter;      /* instructions executed so far (all code) */
static uint64_t start_count;  /* counter when `begin` was entered */
static bool in_interval;
static uint64_t nested_begins; /* `begin` entered again before `end` (restarts the interval) */
static uint64_t stray_ends;    /* `end` entered outside an interval */
static uint64_t misplaced;     /* a marker found inside a block instead of at its start */

/* profile=: one record per translated block (a block retranslated later gets another record; the
 * dump adds them up by address). */
typedef struct tb_prof {
    uint64_t vaddr;
    uint64_t n;
    uint64_t execs;
    uint64_t snap; /* execs when interval profile_interval began */
    uint64_t win;  /* executions inside that interval */
    struct tb_prof *next;
} tb_prof_t;
static const char *profile_path;
static tb_prof_t *profiles;
static uint64_t profile_interval = UINT64_MAX; /* UINT64_MAX: whole run */
static bool profile_window_open;
static bool profile_window_done;

/* Interval profile: snapshot every block's count when the interval begins and take the difference
 * at its end (blocks keep counting afterwards, so the difference is kept apart). Blocks translated
 * inside the interval start from 0, which is their count before it. */
static void profile_window(bool open)
{
    tb_prof_t *p;
    for (p = profiles; p != NULL; p = p->next) {
        if (open) {
            p->snap = p->execs;
        } else {
            p->win = p->execs - p->snap;
        }
    }
    profile_window_open = open;
    profile_window_done = !open;
}

static uint64_t *intervals;
static size_t n_intervals;
static size_t cap_intervals;

static void record(uint64_t v)
{
    if (n_intervals == cap_intervals) {
        size_t cap = cap_intervals != 0 ? 2 * cap_intervals : 4096;
        uint64_t *p = realloc(intervals, cap * sizeof *p);
        if (p == NULL) {
            qemu_plugin_outs("icount: out of memory\n");
            exit(1);
        }
        intervals = p;
        cap_intervals = cap;
    }
    intervals[n_intervals++] = v;
    if (verbose) {
        char line[96];
        snprintf(line, sizeof line, "icount: interval %zu: %" PRIu64 "\n", n_intervals - 1, v);
        qemu_plugin_outs(line);
    }
}

static void on_begin(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    if (in_interval) {
        ++nested_begins;
    }
    in_interval = true;
    start_count = counter;
    if (profile_path != NULL && profile_interval == n_intervals && !profile_window_done) {
        profile_window(true);
    }
    counter += (uint64_t)(uintptr_t)udata;
}

static void on_end(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    if (in_interval) {
        record(counter - start_count);
        in_interval = false;
        if (profile_window_open) {
            profile_window(false);
        }
    } else {
        ++stray_ends;
    }
    counter += (uint64_t)(uintptr_t)udata;
}

static void on_translate(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    uint64_t va = qemu_plugin_tb_vaddr(tb);
    size_t i;
    (void)id;

    for (i = 1; i < n; ++i) {
        uint64_t a = qemu_plugin_insn_vaddr(qemu_plugin_tb_get_insn(tb, i));
        if (a == addr_begin || a == addr_end) {
            ++misplaced;
        }
    }
    if (va == addr_begin) {
        qemu_plugin_register_vcpu_tb_exec_cb(tb, on_begin, QEMU_PLUGIN_CB_NO_REGS, (void *)(uintptr_t)n);
    } else if (va == addr_end) {
        qemu_plugin_register_vcpu_tb_exec_cb(tb, on_end, QEMU_PLUGIN_CB_NO_REGS, (void *)(uintptr_t)n);
    } else {
        qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &counter, (uint64_t)n);
    }
    if (profile_path != NULL && !profile_window_done) {
        tb_prof_t *p = calloc(1, sizeof *p);
        if (p != NULL) {
            p->vaddr = va;
            p->n = n;
            p->next = profiles;
            profiles = p;
            qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &p->execs, 1u);
        }
    }
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a;
    uint64_t y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

static void on_plugin_exit(qemu_plugin_id_t id, void *udata)
{
    char line[320];
    (void)id;
    (void)udata;

    if (out_path != NULL) {
        FILE *f = fopen(out_path, "w");
        if (f == NULL) {
            qemu_plugin_outs("icount: cannot open out= file\n");
        } else {
            size_t i;
            for (i = 0; i < n_intervals; ++i) {
                fprintf(f, "%" PRIu64 "\n", intervals[i]);
            }
            fclose(f);
        }
    }
    if (profile_path != NULL) {
        FILE *f = fopen(profile_path, "w");
        if (f == NULL) {
            qemu_plugin_outs("icount: cannot open profile= file\n");
        } else {
            const tb_prof_t *p;
            if (profile_interval != UINT64_MAX && !profile_window_done) {
                qemu_plugin_outs("icount: profile_interval never completed\n");
            }
            for (p = profiles; p != NULL; p = p->next) {
                uint64_t ex = profile_interval == UINT64_MAX ? p->execs : p->win;
                if (ex != 0) {
                    fprintf(f, "%#" PRIx64 " %" PRIu64 " %" PRIu64 "\n", p->vaddr, p->n, ex);
                }
            }
            fclose(f);
        }
    }
    if (n_intervals == 0) {
        snprintf(line, sizeof line,
                 "icount: intervals=0 total=%" PRIu64 " nested=%" PRIu64 " stray=%" PRIu64
                 " misplaced=%" PRIu64 "\n",
                 counter, nested_begins, stray_ends, misplaced);
    } else {
        uint64_t sum = 0, mx = 0;
        size_t argmax = 0, i;
        uint64_t *sorted = malloc(n_intervals * sizeof *sorted);
        uint64_t median;
        for (i = 0; i < n_intervals; ++i) {
            sum += intervals[i];
            if (intervals[i] > mx) {
                mx = intervals[i];
                argmax = i;
            }
        }
        if (sorted == NULL) {
            qemu_plugin_outs("icount: out of memory\n");
            return;
        }
        memcpy(sorted, intervals, n_intervals * sizeof *sorted);
        qsort(sorted, n_intervals, sizeof *sorted, cmp_u64);
        /* lower median for an even count: always an observed value */
        median = sorted[(n_intervals - 1) / 2];
        snprintf(line, sizeof line,
                 "icount: intervals=%zu min=%" PRIu64 " median=%" PRIu64 " max=%" PRIu64
                 " mean=%.1f argmax=%zu total=%" PRIu64 " nested=%" PRIu64 " stray=%" PRIu64
                 " misplaced=%" PRIu64 "\n",
                 n_intervals, sorted[0], median, mx, (double)sum / (double)n_intervals, argmax, counter,
                 nested_begins, stray_ends, misplaced);
        free(sorted);
    }
    qemu_plugin_outs(line);
}

static int parse_addr(const char *s, uint64_t *out)
{
    char *end = NULL;
    unsigned long long v = strtoull(s, &end, 0);
    if (end == s || *end != '\0') {
        return -1;
    }
    *out = (uint64_t)v & ~(uint64_t)1u; /* Thumb bit of a function symbol */
    return 0;
}

QEMU_PLUGIN_EXPORT int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc,
                                           char **argv)
{
    int i;
    (void)info;
    for (i = 0; i < argc; ++i) {
        const char *a = argv[i];
        if (strncmp(a, "begin=", 6) == 0) {
            if (parse_addr(a + 6, &addr_begin) != 0) {
                goto bad;
            }
        } else if (strncmp(a, "end=", 4) == 0) {
            if (parse_addr(a + 4, &addr_end) != 0) {
                goto bad;
            }
        } else if (strncmp(a, "out=", 4) == 0) {
            out_path = a + 4;
        } else if (strncmp(a, "profile=", 8) == 0) {
            profile_path = a + 8;
        } else if (strncmp(a, "profile_interval=", 17) == 0) {
            char *end = NULL;
            profile_interval = strtoull(a + 17, &end, 0);
            if (end == a + 17 || *end != '\0') {
                goto bad;
            }
        } else if (strcmp(a, "verbose=on") == 0 || strcmp(a, "verbose=true") == 0) {
            verbose = true;
        } else if (strcmp(a, "verbose=off") == 0 || strcmp(a, "verbose=false") == 0) {
            verbose = false;
        } else {
            goto bad;
        }
        continue;
    bad:
        fprintf(stderr, "icount: bad argument '%s' (expected begin=ADDR end=ADDR [out=FILE] [profile=FILE] [profile_interval=K] [verbose=on])\n", a);
        return -1;
    }
    if (addr_begin == UINT64_MAX || addr_end == UINT64_MAX || addr_begin == addr_end) {
        fprintf(stderr, "icount: begin=ADDR and end=ADDR (two different addresses) are required\n");
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translate);
    qemu_plugin_register_atexit_cb(id, on_plugin_exit, NULL);
    return 0;
}
