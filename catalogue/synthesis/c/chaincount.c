/* chaincount: number synthesis inside nauty's genbg (McKay & Piperno 2014).
 *
 * Compiled together with genbg.c (-DPRUNE1=chain_prune -DOUTPROC=chain_out
 * -DSUMMARY=chain_summary, WORDSIZE 64): genbg builds a bicoloured graph of links
 * (first class, vertices 0..n1-1) and joints (second class), adding one joint at a time
 * with all its links.  Every intermediate graph passes through chain_prune, which cuts
 * the whole subtree below a graph that
 *
 *   - is degenerate: some link subset S, 2 <= |S| < n1, has 3(|S| - 1) - 2 c(S) <= 0
 *     with c(S) = sum over joints J of max(0, |S & J| - 1) (Pozhbelko & Kuts 2020);
 *     c(S) never decreases when a joint is added, so every descendant is degenerate
 *     too, and only the subsets meeting the new joint in two or more links can have
 *     become degenerate (the parent passed);
 *   - cannot reach the requested row any more (environment MULTILOOP_LA, MULTILOOP_MJA:
 *     the link assortment n_2, n_3, ... and the multiple-joint assortment V_2, V_3, ...
 *     as comma lists, an empty list for none; unset or "*": not restricted): a joint's
 *     multiplicity is fixed when it is added and a link's
 *     degree only grows, so "more joints of multiplicity j than V_j" and "more links of
 *     degree >= d than the row has" stay true in every descendant.
 *
 * genbg's canonical augmentation reaches each output graph through a unique chain of
 * ancestors, each a subgraph of it; a non-degenerate graph of the row has only
 * non-degenerate ancestors that can still reach the row, so no chain is lost.
 *
 * Every output graph (connected, non-degenerate, of the row when one is set) is tallied
 * by its (LA, MJA); at the end the tallies are printed to stdout, one line each:
 *     LA <n_2,n_3,...> MJA <V_2,V_3,...> <chains>
 * followed by "total <chains> graphs <nodes> pruned <nodes>".
 */
#include "gtools.h"

#define MAXLINKS 24
#define MAXDEG 24
#define TABLE_SIZE (1 << 16)

static int row_set = -1;             /* -1 unread, else 0 or 1 */
static int la_set, mja_set;          /* which assortments are restricted */
static int want_la[MAXDEG + 2];      /* links of degree d (index d) */
static int want_mja[MAXDEG + 2];     /* joints of multiplicity j (index j), j >= 2 */
static int want_la_ge[MAXDEG + 3];   /* links of degree >= d */

typedef struct { unsigned long long key_la, key_mja; long long count; int used; } entry;
static entry table[TABLE_SIZE];
static long long n_pruned = 0, n_visited = 0;

static void parse_list(const char *s, int *out, int first) {
    int k = first;
    while (s && *s && k <= MAXDEG) {
        out[k++] = (int)strtol(s, (char **)&s, 10);
        while (*s == ',' || *s == '-' || *s == ' ') s++;
    }
}

static int restricted(const char *s) { return s != NULL && strcmp(s, "*") != 0; }

static void read_row(void) {
    const char *la = getenv("MULTILOOP_LA"), *mja = getenv("MULTILOOP_MJA");
    la_set = restricted(la);
    mja_set = restricted(mja);
    row_set = la_set || mja_set;
    if (la_set) parse_list(la, want_la, 2);
    if (mja_set) parse_list(mja, want_mja, 2);
    want_la_ge[MAXDEG + 2] = 0;
    for (int d = MAXDEG + 1; d >= 0; d--) want_la_ge[d] = want_la_ge[d + 1] + want_la[d];
}

/* link masks of the joints (bit i = link i) */
static int joint_masks(graph *g, int n1, int n2, unsigned *mask) {
    for (int a = 0; a < n2; a++) {
        setword w = g[n1 + a];
        unsigned mk = 0;
        for (int i = 0; i < n1; i++)
            if (w & bit[i]) mk |= 1u << i;
        mask[a] = mk;
    }
    return n2;
}

/* The degeneracy test of a new joint J added to a non-degenerate graph of k joints.
 *
 * Only a subset S with |S & J| >= 2 can have become degenerate, and for it
 * c_{k+1}(S) = c_k(S) + |S & J| - 1, so S is degenerate iff
 *     Q_k[S] + 2 |S & J| >= 0,   Q_k[S] = 2 c_k(S) - 3|S| + 1.
 * (The whole link set never qualifies: there the left side is -F of the partial chain,
 * and F only falls as joints are added, to F >= 1 at the end.)
 * Q_k is kept for every level of genbg's depth-first search (the parent of a candidate
 * is the graph without its newest joint) and updated by one joint in 2^n steps; the test
 * of a candidate scans Q_k in blocks of 256 subsets with the low bits' |S & J| from a
 * table, which the compiler vectorises. */
#define LOW 8
static int tab_n = -1;                   /* links the tables are built for */
static signed char *qtab[WORDSIZE + 1];  /* Q_k, k = joints placed */
static unsigned levmask[WORDSIZE];       /* the joint placed at each level */
static int levels = 0;                   /* Q_0 .. Q_levels are valid */
static unsigned char popc[1 << 16];

static void tables_for(int n1) {
    if (tab_n == n1) return;
    if (n1 > 16) { fprintf(stderr, "chaincount: at most 16 links\n"); exit(2); }
    for (int s = 0; s < (1 << 16); s++) popc[s] = (unsigned char)__builtin_popcount(s);
    for (int k = 0; k <= WORDSIZE; k++) {
        free(qtab[k]);
        qtab[k] = malloc((size_t)1 << n1);
    }
    for (unsigned s = 0; s < (1u << n1); s++) qtab[0][s] = (signed char)(1 - 3 * __builtin_popcount(s));
    levels = 0;
    tab_n = n1;
}

static void add_level(int k, unsigned J, int n1) {   /* Q_{k+1} from Q_k and joint J */
    int low = n1 < LOW ? n1 : LOW, width = 1 << low;
    unsigned jlo = J & ((1u << low) - 1), jhi = J >> low;
    signed char tlo[1 << LOW];
    for (int lo = 0; lo < width; lo++) tlo[lo] = (signed char)popc[lo & jlo];
    for (unsigned hi = 0; hi < (1u << (n1 - low)); hi++) {
        signed char th = (signed char)popc[hi & jhi];
        const signed char *q = qtab[k] + ((size_t)hi << low);
        signed char *out = qtab[k + 1] + ((size_t)hi << low);
        for (int lo = 0; lo < width; lo++) {
            signed char t = (signed char)(th + tlo[lo]);
            out[lo] = (signed char)(q[lo] + (t > 1 ? 2 * (t - 1) : 0));
        }
    }
    levmask[k] = J;
}

static int block_hits(const signed char *row, const signed char *tlo, signed char th, int width) {
    int hit = 0;
    for (int lo = 0; lo < width; lo++) {
        signed char t = (signed char)(th + tlo[lo]);
        hit |= (t >= 2) & (row[lo] + 2 * t >= 0);
    }
    return hit;
}

static int degenerate_with_last(const unsigned *mask, int n1, int n2) {
    int k = n2 - 1, valid = 0;
    tables_for(n1);
    while (valid < k && valid < levels && levmask[valid] == mask[valid]) valid++;
    for (int l = valid; l < k; l++) add_level(l, mask[l], n1);
    levels = k;
    const signed char *q = qtab[k];
    unsigned J = mask[k];
    int low = n1 < LOW ? n1 : LOW, width = 1 << low;
    unsigned jlo = J & ((1u << low) - 1), jhi = J >> low;
    signed char tlo[1 << LOW];
    for (int lo = 0; lo < width; lo++) tlo[lo] = (signed char)popc[lo & jlo];
    /* the blocks whose high links include all of J's first (a degenerate subset holds
     * at least two of J's links, mostly all of them), then the others */
    unsigned nhi = 1u << (n1 - low), free_hi = (nhi - 1) & ~jhi;
    for (int pass = 0; pass < 2; pass++) {
        unsigned sub = 0;
        do {
            unsigned hi = pass ? sub : (sub | jhi);
            sub = (sub - (pass ? (nhi - 1) : free_hi)) & (pass ? (nhi - 1) : free_hi);
            if (pass && (hi & jhi) == jhi) continue;       /* scanned in the first pass */
            if (popc[hi & jhi] + popc[jlo] < 2) continue;   /* fewer than two of J's links */
            if (block_hits(q + ((size_t)hi << low), tlo, (signed char)popc[hi & jhi], width)) return 1;
        } while (sub);
    }
    return 0;
}

static int beyond_row(graph *g, int *deg, int n1, int n2) {
    int mult[MAXDEG + 2] = {0}, ge[MAXDEG + 3] = {0};
    for (int a = 0; a < n2; a++) {
        int j = deg[n1 + a] - 1;
        if (j > MAXDEG) return 1;
        if (mja_set && j >= 2 && ++mult[j] > want_mja[j]) return 1;
    }
    if (!la_set) return 0;
    for (int i = 0; i < n1; i++) {
        int d = deg[i] > MAXDEG ? MAXDEG : deg[i];
        for (int e = 0; e <= d; e++) ge[e]++;
    }
    for (int e = 0; e <= MAXDEG; e++)
        if (ge[e] > want_la_ge[e]) return 1;
    (void)g;
    return 0;
}

int chain_prune(graph *g, int *deg, int n1, int n2, int maxn2) {
    unsigned mask[WORDSIZE];
    (void)maxn2;
    if (row_set < 0) read_row();
    n_visited++;
    if (row_set && beyond_row(g, deg, n1, n2)) { n_pruned++; return 1; }
    joint_masks(g, n1, n2, mask);
    if (n2 >= 2 && degenerate_with_last(mask, n1, n2)) { n_pruned++; return 1; }
    return 0;
}

static void tally(unsigned long long la, unsigned long long mja) {
    unsigned long long h = (la * 0x9E3779B97F4A7C15ull) ^ (mja * 0xC2B2AE3D27D4EB4Full);
    unsigned slot = (unsigned)(h >> 48) & (TABLE_SIZE - 1);
    while (table[slot].used && (table[slot].key_la != la || table[slot].key_mja != mja))
        slot = (slot + 1) & (TABLE_SIZE - 1);
    table[slot].used = 1;
    table[slot].key_la = la;
    table[slot].key_mja = mja;
    table[slot].count++;
}

/* counts packed 4 bits each: degree d (>= 2) at bits 4(d-2); n <= 15 links */
void chain_out(FILE *f, graph *g, int n1, int n2) {
    int la[MAXDEG + 2] = {0}, mja[MAXDEG + 2] = {0};
    (void)f;
    for (int v = 0; v < n1; v++) la[POPCOUNT(g[v])]++;
    for (int a = 0; a < n2; a++) mja[POPCOUNT(g[n1 + a]) - 1]++;
    if (la_set)
        for (int d = 0; d <= MAXDEG; d++) if (la[d] != want_la[d]) return;
    if (mja_set)
        for (int j = 2; j <= MAXDEG; j++) if (mja[j] != want_mja[j]) return;
    unsigned long long kla = 0, kmja = 0;
    for (int d = 2; d < 18; d++) kla |= (unsigned long long)(la[d] & 15) << (4 * (d - 2));
    for (int j = 2; j < 18; j++) kmja |= (unsigned long long)(mja[j] & 15) << (4 * (j - 2));
    tally(kla, kmja);
}

static void print_packed(unsigned long long k) {
    int last = -1;
    for (int d = 0; d < 16; d++) if ((k >> (4 * d)) & 15) last = d;
    if (last < 0) { printf("-"); return; }
    for (int d = 0; d <= last; d++) printf(d ? ",%llu" : "%llu", (k >> (4 * d)) & 15);
}

void chain_summary(nauty_counter nout, double cpu) {
    long long total = 0;
    for (int s = 0; s < TABLE_SIZE; s++) {
        if (!table[s].used) continue;
        printf("LA ");
        print_packed(table[s].key_la);
        printf(" MJA ");
        print_packed(table[s].key_mja);
        printf(" %lld\n", table[s].count);
        total += table[s].count;
    }
    printf("total %lld graphs %lld pruned %lld cpu %.2f\n", total, n_visited, n_pruned, cpu);
    (void)nout;
    fflush(stdout);
}
