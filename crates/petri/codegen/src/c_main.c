
#include <ctype.h>
#include <errno.h>
#include <stdarg.h>

/* ASCII case-insensitive equality (strcasecmp is POSIX, not C99). */
static int same_word(const char *a, const char *b)
{
    for (; *a && *b; a++, b++)
        if (tolower((unsigned char)*a) != tolower((unsigned char)*b))
            return 0;
    return *a == *b;
}

static char *fired_buf;
static size_t fired_len, fired_cap;

/* Appends a fired transition's name to this scan's `fired` column. */
static void pn_fired(int t)
{
    const char *name = transition_names[t];
    size_t n = strlen(name);
    if (fired_len + n + 2 > fired_cap) {
        fired_cap = (fired_len + n + 2) * 2;
        fired_buf = realloc(fired_buf, fired_cap);
        if (!fired_buf) {
            fputs("error: out of memory\n", stderr);
            exit(1);
        }
    }
    if (fired_len)
        fired_buf[fired_len++] = ' ';
    memcpy(fired_buf + fired_len, name, n);
    fired_len += n;
    fired_buf[fired_len] = '\0';
}

static void bad_input(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("error: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(2);
}

/* A CSV field, quoted only when it holds a comma, quote or line break. */
static void print_field(const char *s)
{
    if (!strpbrk(s, ",\"\n\r")) {
        fputs(s, stdout);
        return;
    }
    putchar('"');
    for (; *s; s++) {
        if (*s == '"')
            putchar('"');
        putchar(*s);
    }
    putchar('"');
}

/* Seconds with as many decimals as needed: 0.01, 1.5, 2. */
static void print_time(uint64_t ns)
{
    printf("%llu", (unsigned long long)(ns / 1000000000ull));
    unsigned frac = (unsigned)(ns % 1000000000ull);
    if (frac) {
        char buf[16];
        snprintf(buf, sizeof buf, "%09u", frac);
        int len = 9;
        while (buf[len - 1] == '0')
            len--;
        buf[len] = '\0';
        printf(".%s", buf);
    }
}

/* digits[.digits] times scale nanoseconds, exactly; -1 when malformed or finer than 1 ns. */
static int parse_decimal(const char *s, size_t len, uint64_t scale, uint64_t *out)
{
    size_t i = 0, digits = 0;
    uint64_t total = 0;
    for (; i < len && isdigit((unsigned char)s[i]); i++, digits++) {
        uint64_t d = (uint64_t)(s[i] - '0');
        if (total > (UINT64_MAX - d) / 10)
            return -1;
        total = total * 10 + d;
    }
    if (scale && total > UINT64_MAX / scale)
        return -1;
    total *= scale;
    if (i < len && s[i] == '.') {
        uint64_t place = scale;
        for (i++; i < len && isdigit((unsigned char)s[i]); i++, digits++) {
            uint64_t d = (uint64_t)(s[i] - '0');
            if (place % 10 != 0) {
                if (d != 0)
                    return -1;
                continue;
            }
            place /= 10;
            total += d * place;
        }
    }
    if (i != len || digits == 0)
        return -1;
    *out = total;
    return 0;
}

/* An IEC TIME literal (T#1m30s, 10ms) or decimal seconds (0.01), as nanoseconds. */
static int parse_time(const char *text, uint64_t *ns)
{
    static const struct {
        const char *unit;
        uint64_t scale;
        int rank;
    } units[] = {{"d", 86400000000000ull, 0}, {"h", 3600000000000ull, 1},
                 {"ms", 1000000ull, 4},       {"us", 1000ull, 5},
                 {"ns", 1ull, 6},             {"m", 60000000000ull, 2},
                 {"s", 1000000000ull, 3}};
    char buf[128];
    size_t len = strlen(text);
    while (len && isspace((unsigned char)*text)) {
        text++;
        len--;
    }
    while (len && isspace((unsigned char)text[len - 1]))
        len--;
    if (len == 0 || len >= sizeof buf)
        return -1;
    for (size_t i = 0; i < len; i++)
        buf[i] = (char)tolower((unsigned char)text[i]);
    buf[len] = '\0';
    char *body = buf;
    int iec = isalpha((unsigned char)buf[len - 1]);
    if (strncmp(body, "time#", 5) == 0) {
        body += 5;
        iec = 1;
    } else if (strncmp(body, "t#", 2) == 0) {
        body += 2;
        iec = 1;
    }
    if (!iec)
        return parse_decimal(body, strlen(body), 1000000000ull, ns);
    char clean[128];
    size_t k = 0;
    for (char *c = body; *c; c++)
        if (*c != '_')
            clean[k++] = *c;
    clean[k] = '\0';
    if (k == 0)
        return -1;
    uint64_t total = 0;
    int last_rank = -1, saw_fraction = 0;
    const char *s = clean;
    while (*s) {
        const char *num = s;
        while (isdigit((unsigned char)*s) || *s == '.')
            s++;
        size_t nlen = (size_t)(s - num);
        if (nlen == 0 || saw_fraction)
            return -1;
        int found = -1;
        for (int u = 0; u < 7; u++)
            if (strncmp(s, units[u].unit, strlen(units[u].unit)) == 0) {
                found = u;
                break;
            }
        if (found < 0 || units[found].rank <= last_rank)
            return -1;
        last_rank = units[found].rank;
        saw_fraction = memchr(num, '.', nlen) != NULL;
        uint64_t v;
        if (parse_decimal(num, nlen, units[found].scale, &v) || total > UINT64_MAX - v)
            return -1;
        total += v;
        s += strlen(units[found].unit);
    }
    *ns = total;
    return 0;
}

/* 0/1, TRUE/FALSE in any case, or a signed integer. */
static int parse_value(const char *s, int64_t *v)
{
    if (same_word(s, "true")) {
        *v = 1;
        return 0;
    }
    if (same_word(s, "false")) {
        *v = 0;
        return 0;
    }
    if (!*s)
        return -1;
    const char *p = s;
    if (*p == '+' || *p == '-')
        p++;
    if (!*p)
        return -1;
    for (const char *q = p; *q; q++)
        if (!isdigit((unsigned char)*q))
            return -1;
    char *end;
    errno = 0;
    long long x = strtoll(s, &end, 10);
    if (errno || *end)
        return -1;
    *v = (int64_t)x;
    return 0;
}

/* Splits `line` at commas in place, trimming each cell; returns the number of cells. */
static size_t split_cells(char *line, char **cells, size_t max)
{
    size_t n = 0;
    char *start = line;
    for (;;) {
        char *comma = strchr(start, ',');
        if (comma)
            *comma = '\0';
        while (isspace((unsigned char)*start))
            start++;
        size_t len = strlen(start);
        while (len && isspace((unsigned char)start[len - 1]))
            start[--len] = '\0';
        if (n < max)
            cells[n] = start;
        n++;
        if (!comma)
            return n;
        start = comma + 1;
    }
}

typedef struct {
    uint64_t t;
    int64_t v;
} change_t;

static change_t *changes[N_INPUTS + 1];
static size_t n_changes[N_INPUTS + 1];

/* The trace's input columns: the timeline's, in its order, then the others as declared
   (the order `petriplc sim` uses). */
static int in_order[N_INPUTS + 1];
static int n_in_order;

static void order_input(int input)
{
    for (int k = 0; k < n_in_order; k++)
        if (in_order[k] == input)
            return;
    in_order[n_in_order++] = input;
}

static void add_change(int input, uint64_t t, int64_t v)
{
    changes[input] = realloc(changes[input], (n_changes[input] + 1) * sizeof(change_t));
    if (!changes[input]) {
        fputs("error: out of memory\n", stderr);
        exit(1);
    }
    changes[input][n_changes[input]].t = t;
    changes[input][n_changes[input]].v = v;
    n_changes[input]++;
}

/* Reads a timeline CSV; returns the time of its last row. */
static uint64_t read_timeline(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        bad_input("cannot read timeline %s: %s", path, strerror(errno));
    size_t cap = 1 << 16, len = 0;
    char *text = malloc(cap);
    size_t got;
    while (text && (got = fread(text + len, 1, cap - len - 1, f)) > 0) {
        len += got;
        if (cap - len < 2) {
            cap *= 2;
            text = realloc(text, cap);
        }
    }
    fclose(f);
    if (!text) {
        fputs("error: out of memory\n", stderr);
        exit(1);
    }
    text[len] = '\0';
    char *line = text;
    if (strncmp(line, "\xEF\xBB\xBF", 3) == 0)
        line += 3;
    size_t columns = 0;
    int *input_of = NULL;
    uint64_t last = 0;
    int header_seen = 0, line_no = 0;
    char **cells = NULL;
    while (line) {
        char *next = strchr(line, '\n');
        if (next)
            *next++ = '\0';
        line_no++;
        size_t l = strlen(line);
        if (l && line[l - 1] == '\r')
            line[--l] = '\0';
        const char *t = line;
        while (isspace((unsigned char)*t))
            t++;
        if (!*t || *t == '#') {
            line = next;
            continue;
        }
        if (!header_seen) {
            header_seen = 1;
            size_t n = 1;
            for (const char *c = line; *c; c++)
                n += *c == ',';
            cells = malloc(n * sizeof(char *));
            input_of = malloc(n * sizeof(int));
            columns = split_cells(line, cells, n);
            if (!same_word(cells[0], "time"))
                bad_input("%s:%d: the first header cell is `%s`; it must be `time`", path,
                          line_no, cells[0]);
            if (columns == 1)
                bad_input("%s:%d: the header names no signals", path, line_no);
            for (size_t c = 1; c < columns; c++) {
                input_of[c] = -1;
                for (int i = 0; i < N_INPUTS; i++)
                    if (strcmp(cells[c], input_names[i]) == 0)
                        input_of[c] = i;
                for (size_t d = 1; d < c; d++)
                    if (strcmp(cells[c], cells[d]) == 0)
                        bad_input("%s:%d: column `%s` appears twice", path, line_no,
                                  cells[c]);
                if (input_of[c] >= 0)
                    order_input(input_of[c]);
                if (input_of[c] < 0) {
                    for (int o = 0; o < N_OUTPUTS; o++)
                        if (strcmp(cells[c], output_names[o]) == 0)
                            bad_input("timeline %s: column `%s` is an output of the "
                                      "controller; a timeline drives inputs only",
                                      path, cells[c]);
                    bad_input("timeline %s: column `%s` is not an input of the controller",
                              path, cells[c]);
                }
            }
            line = next;
            continue;
        }
        char **row = malloc((columns + 1) * sizeof(char *));
        size_t n = split_cells(line, row, columns + 1);
        if (n != columns)
            bad_input("%s:%d: the row has %zu cells but the header has %zu", path, line_no, n,
                      columns);
        uint64_t time;
        if (!*row[0] || parse_time(row[0], &time))
            bad_input("%s:%d: bad time `%s`", path, line_no, row[0]);
        if (time < last)
            bad_input("%s:%d: rows must be sorted by time", path, line_no);
        last = time;
        for (size_t c = 1; c < columns; c++) {
            if (!*row[c])
                continue;
            int64_t v;
            if (parse_value(row[c], &v))
                bad_input("%s:%d: `%s` is not a value for `%s`", path, line_no, row[c],
                          cells[c]);
            if (input_is_bool[input_of[c]] && v != 0 && v != 1)
                bad_input("timeline column `%s` sets boolean input `%s` to %lld", cells[c],
                          cells[c], (long long)v);
            add_change(input_of[c], time, v);
        }
        free(row);
        line = next;
    }
    if (!header_seen)
        bad_input("%s: the timeline has no header", path);
    return last;
}

int main(int argc, char **argv)
{
    const char *timeline = NULL;
    uint64_t period = DEFAULT_PERIOD_NS, until = 0;
    int until_given = 0;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--period") == 0 && i + 1 < argc) {
            if (parse_time(argv[++i], &period) || period == 0)
                bad_input("--period %s: give a period greater than 0 (e.g. 10ms)", argv[i]);
        } else if (strcmp(argv[i], "--until") == 0 && i + 1 < argc) {
            if (parse_time(argv[++i], &until))
                bad_input("--until %s: not a duration (e.g. 9s)", argv[i]);
            until_given = 1;
        } else if (argv[i][0] == '-' && argv[i][1]) {
            bad_input("unknown option %s; usage: %s [TIMELINE.csv] [--period T] [--until T]",
                      argv[i], argv[0]);
        } else if (!timeline) {
            timeline = argv[i];
        } else {
            bad_input("one timeline only; usage: %s [TIMELINE.csv] [--period T] [--until T]",
                      argv[0]);
        }
    }
    if (period % 1000000ull != 0)
        bad_input("--period: this program counts time in whole milliseconds");
    uint64_t end = timeline ? read_timeline(timeline) : 0;
    if (!until_given)
        until = timeline ? end + 1000000000ull : 10000000000ull;

    for (int i = 0; i < N_INPUTS; i++)
        order_input(i);

    fputs("time", stdout);
    for (int k = 0; k < N_INPUTS; k++) {
        static char col[4096];
        snprintf(col, sizeof col, "in:%s", input_names[in_order[k]]);
        putchar(',');
        print_field(col);
    }
    for (int o = 0; o < N_OUTPUTS; o++) {
        putchar(',');
        print_field(output_names[o]);
    }
    for (int p = 0; p < N_PLACES; p++) {
        static char col[4096];
        snprintf(col, sizeof col, "m:%s", place_names[p]);
        putchar(',');
        print_field(col);
    }
    fputs(",fired\n", stdout);

    inputs_t in;
    outputs_t out;
    memset(&in, 0, sizeof in);
    memset(&out, 0, sizeof out);
    size_t next[N_INPUTS + 1] = {0};
    int64_t in_value[N_INPUTS + 1] = {0}, last_in[N_INPUTS + 1] = {0};
    int64_t last_out[N_OUTPUTS + 1] = {0};
    uint32_t last_m[N_PLACES + 1] = {0};
    for (uint64_t k = 0;; k++) {
        if (period > 0 && k > until / period)
            break;
        uint64_t t = k * period;
        for (int i = 0; i < N_INPUTS; i++) {
            while (next[i] < n_changes[i] && changes[i][next[i]].t <= t) {
                set_input(&in, i, changes[i][next[i]].v);
                in_value[i] = changes[i][next[i]].v;
                next[i]++;
            }
        }
        fired_len = 0;
        if (fired_buf)
            fired_buf[0] = '\0';
        int r = step(&in, &out, t / 1000000ull);
        if (r != PN_OK) {
            fflush(stdout);
            fputs("error: at t=", stderr);
            fflush(stdout);
            fprintf(stderr, "%llu ms: %s\n", (unsigned long long)(t / 1000000ull),
                    r == PN_UNSTABLE ? "the net is unstable (still firing after the last pass)"
                                     : "a place would hold more than 4294967295 tokens");
            return 1;
        }
        int changed = k == 0 || fired_len > 0;
        for (int i = 0; i < N_INPUTS; i++) {
            changed |= in_value[i] != last_in[i];
            last_in[i] = in_value[i];
        }
        for (int o = 0; o < N_OUTPUTS; o++) {
            int64_t v = get_output(&out, o);
            changed |= v != last_out[o];
            last_out[o] = v;
        }
        for (int p = 0; p < N_PLACES; p++) {
            changed |= M[p] != last_m[p];
            last_m[p] = M[p];
        }
        if (!changed)
            continue;
        print_time(t);
        for (int k = 0; k < N_INPUTS; k++) {
            int i = in_order[k];
            printf(",%lld", (long long)(input_is_bool[i] ? in_value[i] != 0 : in_value[i]));
        }
        for (int o = 0; o < N_OUTPUTS; o++)
            printf(",%lld", (long long)last_out[o]);
        for (int p = 0; p < N_PLACES; p++)
            printf(",%u", (unsigned)last_m[p]);
        putchar(',');
        print_field(fired_buf ? fired_buf : "");
        putchar('\n');
    }
    return 0;
}
