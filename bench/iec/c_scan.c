/* Times one scan (step()) of a net compiled from `petriplc compile --lang c`, built as its own
 * translation unit with cc -O2 and linked with this harness, so nothing is inlined across.
 * Every input is TRUE (the mixer cycles, one transition firing per scan).
 * Usage: c_scan INPUT_BYTES SCANS REPEATS
 * Prints the median wall-clock ns per scan, then the process CPU ns per scan over all runs. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

int step(const void *in, void *out, uint64_t now_ms);

static int cmp(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

int main(int argc, char **argv)
{
    if (argc != 4) {
        fprintf(stderr, "usage: c_scan INPUT_BYTES SCANS REPEATS\n");
        return 2;
    }
    size_t in_size = (size_t)atol(argv[1]);
    long scans = atol(argv[2]);
    int repeats = atoi(argv[3]);
    unsigned char *in = malloc(in_size + 1);
    unsigned char *out = malloc(in_size * 4 + 64);
    memset(in, 1, in_size + 1);
    double *ns = malloc(sizeof(double) * (size_t)repeats);
    uint64_t now = 0;
    struct timespec c0, c1;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c0);
    for (int r = 0; r < repeats; r++) {
        struct timespec t0, t1;
        clock_gettime(CLOCK_MONOTONIC, &t0);
        for (long k = 0; k < scans; k++) {
            step(in, out, now);
            now += 10;
        }
        clock_gettime(CLOCK_MONOTONIC, &t1);
        ns[r] = ((t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec)) / (double)scans;
    }
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c1);
    double cpu = ((c1.tv_sec - c0.tv_sec) * 1e9 + (c1.tv_nsec - c0.tv_nsec)) / ((double)scans * repeats);
    qsort(ns, (size_t)repeats, sizeof(double), cmp);
    printf("%.1f %.1f\n", ns[repeats / 2], cpu);
    return 0;
}
