/* The generated C's side of bench/scan.sh: the C that `petriplc compile --lang c` writes for
 * N mixer copies (crates/petri/sim/examples/scan-copies.rs), scanned on the schedule scan-copies
 * uses (scan k changes one input of copy k mod N), timing the scan loop alone.
 * Build: cc -O2 -DPETRIPLC_MAIN -DGENERATED='"mixers.c"' -o driver driver.c
 * Usage: driver SCANS */
#define main petriplc_trace_main
#include GENERATED
#undef main
#include <time.h>

int main(int argc, char **argv)
{
    long long scans = argc > 1 ? atoll(argv[1]) : 100000;
    int n = N_INPUTS / 4;
    static const char *phase_input[8] = {"B1", "B1", "N2", "N2", "N3", "N3", "N1", "N1"};
    static const int phase_value[8] = {1, 0, 1, 0, 1, 0, 1, 0};
    static const char *names[4] = {"B1", "N2", "N3", "N1"};
    int *idx = malloc(sizeof(int) * 4 * (size_t)n);
    for (int c = 0; c < n; c++)
        for (int j = 0; j < 4; j++) {
            char want[32];
            snprintf(want, sizeof want, "%s_%d", names[j], c);
            idx[c * 4 + j] = -1;
            for (int i = 0; i < N_INPUTS; i++)
                if (strcmp(input_names[i], want) == 0)
                    idx[c * 4 + j] = i;
            if (idx[c * 4 + j] < 0) {
                fprintf(stderr, "driver: no input %s\n", want);
                return 2;
            }
        }
    static inputs_t in;
    static outputs_t out;
    struct timespec a, b;
    clock_gettime(CLOCK_MONOTONIC, &a);
    for (long long k = 0; k < scans; k++) {
        int c = (int)(k % n);
        int ph = (int)((k / n) % 8);
        int j = 0;
        while (strcmp(names[j], phase_input[ph]) != 0)
            j++;
        set_input(&in, idx[c * 4 + j], phase_value[ph]);
        fired_len = 0;
        if (step(&in, &out, (uint64_t)k * 10) != PN_OK) {
            fprintf(stderr, "driver: scan %lld failed\n", k);
            return 1;
        }
    }
    clock_gettime(CLOCK_MONOTONIC, &b);
    double ns = ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / (double)scans;
    unsigned long long h = 0;
    for (int p = 0; p < N_PLACES; p++)
        h += (unsigned long long)M[p] * (unsigned long long)(p + 1);
    printf("scans=%lld ns_per_scan=%.1f checksum=%llu\n", scans, ns, h);
    return 0;
}
