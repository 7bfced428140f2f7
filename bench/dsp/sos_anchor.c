/* The floor for a dsp module's filters: a plain C cascade of second-order sections in
 * transposed direct form II (scipy.signal.sosfilt's arithmetic), stepped one sample at a
 * time as a PLC scan steps it. Prints nanoseconds per section per sample.
 *
 *   cc -O2 -o sos_anchor sos_anchor.c -lm && ./sos_anchor 1000 200000
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

int main(int argc, char **argv) {
    int sections = argc > 1 ? atoi(argv[1]) : 1000;
    long samples = argc > 2 ? atol(argv[2]) : 200000;
    double (*sos)[6] = malloc(sizeof(double[6]) * sections);
    double (*z)[2] = calloc(sections, sizeof(double[2]));
    for (int s = 0; s < sections; s++) {
        double c[6] = {s == 0 ? 0.01 : 1.0, -1.6, 0.8, 1.0, -1.5, 0.7};
        for (int i = 0; i < 6; i++) sos[s][i] = c[i];
    }
    struct timespec a, b;
    volatile double sink = 0;
    clock_gettime(CLOCK_MONOTONIC, &a);
    for (long n = 0; n < samples; n++) {
        double x = sin(n * 0.05);
        for (int s = 0; s < sections; s++) {
            double y = sos[s][0] * x + z[s][0];
            z[s][0] = sos[s][1] * x - sos[s][4] * y + z[s][1];
            z[s][1] = sos[s][2] * x - sos[s][5] * y;
            x = y;
        }
        sink += x;
    }
    clock_gettime(CLOCK_MONOTONIC, &b);
    double ns = (b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec);
    printf("%.3f\n", ns / samples / sections);
    return sink == 12345.0;
}
