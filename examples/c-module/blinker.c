/*
 * blinker - a petriplc module written in C.
 *
 * While the input point is true, toggles the output point (which the module must own)
 * every EVERY scans; when the input goes false it stops blinking and counts afresh next
 * time. Optionally publishes the number of scans done in COUNTER (also owned).
 *
 * Usage: blinker [EVERY [INPUT OUTPUT [COUNTER]]]    (defaults: 5 enable lamp, no counter)
 *
 * The PLC is found through PETRIPLC_CONFIG / PETRIPLC_MODULE / PETRIPLC_PLC_ID (set by
 * `petriplc run`) or --PLCconfig= / --PLCmodule= / --PLCplc_id= on the command line;
 * plc_init removes those, so only the arguments above are left to parse.
 *
 * Exits 0 when the PLC stops, 1 on an error, 2 on bad arguments.
 */
#include <stdio.h>
#include <stdlib.h>

#include "petriplc.h"

static int usage(void)
{
    fprintf(stderr, "usage: blinker [EVERY [INPUT OUTPUT [COUNTER]]]\n");
    plc_close();
    return 2;
}

static plc_pt_t point(const char *name)
{
    plc_pt_t pt = plc_pt_by_name(name);
    if (!plc_pt_valid(pt))
        fprintf(stderr, "blinker: %s\n", plc_last_error());
    return pt;
}

int main(int argc, char **argv)
{
    const char *input = "enable", *output = "lamp", *counter = NULL;
    unsigned long every = 5, ticks = 0, scans = 0;
    plc_pt_t in, out, count = {0, 0};
    uint32_t lamp;
    char *end;
    int rc;

    if (plc_init("blinker", &argc, argv) != PLC_OK) {
        fprintf(stderr, "blinker: %s\n", plc_last_error());
        return 1;
    }
    if (argc > 5 || argc == 3)
        return usage();
    if (argc > 1) {
        every = strtoul(argv[1], &end, 10);
        if (*argv[1] == '\0' || *end != '\0' || every == 0)
            return usage();
    }
    if (argc > 3) {
        input = argv[2];
        output = argv[3];
    }
    if (argc > 4)
        counter = argv[4];

    in = point(input);
    out = point(output);
    if (counter != NULL)
        count = point(counter);
    if (!plc_pt_valid(in) || !plc_pt_valid(out) || (counter != NULL && !plc_pt_valid(count))) {
        plc_close();
        return 1;
    }
    /* The module owns the output: its own map holds the value it last wrote. */
    lamp = plc_get(out);

    while ((rc = plc_scan_beg()) == PLC_OK) {
        if (plc_get(in)) {
            if (++ticks >= every) {
                ticks = 0;
                lamp = !lamp;
                if ((rc = plc_set(out, lamp)) != PLC_OK)
                    break;
            }
        } else {
            ticks = 0;
        }
        scans++;
        if (counter != NULL && (rc = plc_set(count, (uint32_t)scans)) != PLC_OK)
            break;
        if ((rc = plc_scan_end()) != PLC_OK)
            break;
    }

    if (rc != PLC_STOPPING) {
        fprintf(stderr, "blinker: %s (%s)\n", plc_last_error(), plc_strerror(rc));
        plc_close();
        return 1;
    }
    printf("blinker: the PLC is stopping after %lu scans\n", scans);
    plc_close();
    return 0;
}
