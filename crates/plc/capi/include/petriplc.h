/*
 * petriplc.h - the C API of the petriplc soft PLC (libpetriplc.so / libpetriplc.a).
 *
 * A module written in C runs as its own process next to a running PLC (`petriplc run`),
 * in the spirit of MatPLC's library:
 *
 *     int main(int argc, char **argv) {
 *         if (plc_init("blinker", &argc, argv) != PLC_OK) {
 *             fprintf(stderr, "%s\n", plc_last_error());
 *             return 1;
 *         }
 *         plc_pt_t in = plc_pt_by_name("enable");
 *         ...
 *         while (plc_scan_beg() == PLC_OK) {
 *             ... plc_get(in) ... plc_set(out, v) ...
 *             if (plc_scan_end() != PLC_OK) break;
 *         }
 *         plc_close();
 *         return 0;
 *     }
 *
 * Build: cc -I crates/plc/capi/include module.c -L target/debug -lpetriplc -o module
 *
 * Every point has one owner module, the only one allowed to set it. A module works on a
 * private copy of the points (its map): plc_get and plc_set touch only that copy, and
 * plc_update (also done by plc_scan_beg and plc_scan_end) exchanges it with the PLC's
 * global map: the module's own points out, every other point in.
 *
 * Return codes: PLC_OK (0) on success, PLC_STOPPING (1) when the PLC is shutting down and
 * the module should leave its scan loop, a negative PLC_ERR_* on error. After an error,
 * plc_last_error() describes it and says how to fix it.
 *
 * Threads: the library holds one attachment per process, behind a lock; any thread may
 * call any function. plc_last_error() is per thread.
 *
 * Isolation (`location = isolate` in the module's section, MatPLC's --PLCisolate):
 * plc_init forks a proxy process that alone maps the PLC's global map; this process never
 * does, so a module that corrupts its own memory cannot corrupt the PLC's image.
 * plc_update (and plc_scan_beg / plc_scan_end) ask the proxy over a socket to exchange the
 * private map, which both processes share, with the global map, and wait for it.
 * Because it forks, plc_init refuses isolation (PLC_ERR_CONFIG) once the process has more
 * than one thread: call it first thing in main. The proxy is ended when the module closes
 * (plc_close) or exits, and when the thread that called plc_init ends, however it ends.
 * If the proxy is gone, plc_update fails with PLC_ERR_OS.
 */
#ifndef PETRIPLC_H
#define PETRIPLC_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Return codes. */
#define PLC_OK                 0  /* success */
#define PLC_STOPPING           1  /* not an error: the PLC is stopping, leave the scan loop */
#define PLC_ERR_NOT_INIT      (-1)  /* plc_init was not called (or plc_close was) */
#define PLC_ERR_ALREADY_INIT  (-2)  /* plc_init was already called in this process */
#define PLC_ERR_ARGS          (-3)  /* NULL pointer, unknown --PLC option, no module name,
                                       configuration or PLC id, text not UTF-8 */
#define PLC_ERR_CONFIG        (-4)  /* the configuration cannot be read or is invalid */
#define PLC_ERR_MODULE        (-5)  /* the module is not declared in the configuration */
#define PLC_ERR_NOT_RUNNING   (-6)  /* no PLC with this id is running */
#define PLC_ERR_MISMATCH      (-7)  /* the running PLC was started from another configuration */
#define PLC_ERR_POINT         (-8)  /* invalid or stale point handle, unknown transition */
#define PLC_ERR_NOT_OWNER     (-9)  /* the point is owned by another module */
#define PLC_ERR_VALUE         (-10) /* the value does not fit the point, or wrong kind */
#define PLC_ERR_OS            (-11) /* the operating system refused (shared memory) */
#define PLC_ERR_INTERNAL      (-12) /* a bug in libpetriplc; plc_last_error says where */

/*
 * A handle to a plc point, from plc_pt_by_name. Treat it as opaque: copy it, keep it,
 * pass it by value. The zeroed handle ({0, 0}) is invalid. A handle is valid until
 * plc_close.
 */
typedef struct plc_pt_t {
    uint32_t index;   /* the point's index + 1; 0: invalid */
    uint32_t session; /* which plc_init it belongs to */
} plc_pt_t;

/*
 * Attaches this process to a running PLC as module `module`.
 *
 * Which PLC and module, first found wins:
 *   configuration file:  --PLCconfig=FILE,  $PETRIPLC_CONFIG
 *   module name:         --PLCmodule=NAME,  $PETRIPLC_MODULE,  the `module` argument
 *   PLC id:              --PLCplc_id=ID,    $PETRIPLC_PLC_ID,  `plc_id` in [PLC]
 * `petriplc run` sets the three environment variables for the modules it starts; the
 * command-line options are for starting a module by hand. `module` may be NULL.
 *
 * argc/argv are main's (or NULL/NULL). On success the --PLC options are removed from argv
 * (argc updated, argv[argc] = NULL), so the module parses only its own arguments; a `--`
 * ends the options (what follows is left alone). An unknown --PLC option is an error.
 * On failure argv is left as it was.
 *
 * The configuration is read, the module's private map set up with every point at its
 * init value (the first plc_update or plc_scan_beg brings in the PLC's current values),
 * and the PLC's shared memory attached; the PLC must be running with the same
 * configuration.
 *
 * The module's own retentive points (`retain`) are the exception: they hold, from
 * plc_init on, the value given back from the retain file (or, for a restarted module, the
 * one its previous process last committed). A module that keeps a count in one must read
 * it (plc_get) before its first plc_set of it, or the stored value is lost.
 *
 * With `location = isolate` the global map is attached by the proxy process plc_init forks
 * (see Isolation above), and PLC_ERR_CONFIG also means the process already had threads.
 *
 * Returns PLC_OK, or PLC_ERR_ARGS, PLC_ERR_CONFIG, PLC_ERR_MODULE, PLC_ERR_NOT_RUNNING,
 * PLC_ERR_MISMATCH, PLC_ERR_ALREADY_INIT, PLC_ERR_OS.
 */
int plc_init(const char *module, int *argc, char **argv);

/*
 * Detaches from the PLC (the PLC and the other modules go on). Point handles become
 * invalid; plc_init may be called again. Returns PLC_OK, or PLC_ERR_NOT_INIT.
 */
int plc_close(void);

/*
 * The handle of the point called `name`. On error (unknown name, not attached) returns an
 * invalid handle and plc_last_error() says why (for an unknown name, with close matches).
 */
plc_pt_t plc_pt_by_name(const char *name);

/* 1 if `pt` is a valid handle of the current attachment, else 0. */
int plc_pt_valid(plc_pt_t pt);

/*
 * The point's value in the module's map, as its raw bits, zero-extended: a boolean is 0
 * or 1, a signed point's two's complement in its width, a float point's IEEE 754 bits.
 * Returns 0 for an invalid handle (check plc_pt_valid once after the lookup).
 */
uint32_t plc_get(plc_pt_t pt);

/*
 * Sets the point's raw bits in the module's map (see plc_get); the PLC sees it at the next
 * plc_update. Returns PLC_OK, PLC_ERR_POINT, PLC_ERR_NOT_OWNER (only the point's owner may
 * set it) or PLC_ERR_VALUE (bits beyond the point's width).
 */
int plc_set(plc_pt_t pt, uint32_t bits);

/*
 * A signed point's value, sign-extended; an unsigned point's bits; a float point's value
 * truncated towards zero. 0 for an invalid handle.
 */
int32_t plc_get_i32(plc_pt_t pt);

/*
 * Sets an integer point: the value must fit (for an unsigned point, be non-negative).
 * A float point refuses it with PLC_ERR_VALUE (use plc_set_f32). Returns as plc_set.
 */
int plc_set_i32(plc_pt_t pt, int32_t value);

/* A float point's value; an integer point's value converted. 0 for an invalid handle. */
float plc_get_f32(plc_pt_t pt);

/* Sets a float point; an integer point refuses it with PLC_ERR_VALUE. Returns as plc_set. */
int plc_set_f32(plc_pt_t pt, float value);

/*
 * Exchanges the module's map with the PLC's global map, atomically with respect to every
 * other module: the module's own points go out, every other point comes in.
 * Returns PLC_OK, PLC_ERR_NOT_INIT, or PLC_ERR_OS (an isolated module's proxy is gone).
 */
int plc_update(void);

/*
 * Begins a scan: if the module has a `scan_period`, waits for its next deadline (from the
 * second scan on; deadlines are t0 + k*period, t0 being the first scan); then waits until
 * the synchronisation net fires the module's `scan_beg` transition (at once when it has
 * none); then plc_update.
 * Returns PLC_OK, PLC_STOPPING (leave the loop), PLC_ERR_NOT_INIT, or PLC_ERR_OS (as
 * plc_update).
 */
int plc_scan_beg(void);

/*
 * Ends a scan: plc_update, then waits until the net fires the module's `scan_end`
 * transition. Returns PLC_OK, PLC_STOPPING, PLC_ERR_NOT_INIT, or PLC_ERR_OS (as
 * plc_update).
 */
int plc_scan_end(void);

/*
 * Waits until the net fires the transition called `transition` (for modules that
 * synchronise inside their scan). "NULL" returns at once. Returns PLC_OK, PLC_STOPPING,
 * PLC_ERR_POINT (no such transition), PLC_ERR_ARGS or PLC_ERR_NOT_INIT.
 */
int plc_synch(const char *transition);

/* 1 if the PLC is stopping, 0 if not, PLC_ERR_NOT_INIT. Does not wait. */
int plc_stopping(void);

/*
 * The message of this thread's last failed call, "" if none has failed. Valid until this
 * thread's next failing call; never NULL.
 */
const char *plc_last_error(void);

/* A short static description of a return code. Never NULL. */
const char *plc_strerror(int code);

#ifdef __cplusplus
}
#endif

#endif /* PETRIPLC_H */
