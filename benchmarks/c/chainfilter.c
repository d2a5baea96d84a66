/* chainfilter: the compiled yardstick of benchmarks/bench_atlas.py.
 *
 * Reads graph6 lines from nauty's geng (simple joints: every edge is a joint) or genbg
 * (links 0..n-1, joints n..n+m-1) on stdin and counts the non-degenerate chains: no
 * link subset S with 2 <= |S| < n and 3(|S| - 1) - 2 c(S) <= 0, where
 * c(S) = sum over joints J of max(0, |S & J| - 1) (Pozhbelko & Kuts 2020).  Every
 * subset is visited in Gray-code order, c(S) updated in O(degree) per step.
 *
 * usage: genbg ... | chainfilter N M      (M = 0: geng output, edges are joints)
 * prints the number of non-degenerate chains.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAXJ 64

static int n, m;
static int nj;
static unsigned jmask[MAXJ];
static int cnt[MAXJ];
static int joints_of[32][MAXJ], njoints_of[32];

static int bit(const unsigned char *s, long k) {   /* bit k of the graph6 body */
    return ((s[k / 6] - 63) >> (5 - k % 6)) & 1;
}

static int degenerate(void) {
    memset(cnt, 0, sizeof cnt);
    for (int x = 0; x < n; x++) njoints_of[x] = 0;
    for (int a = 0; a < nj; a++)
        for (int x = 0; x < n; x++)
            if (jmask[a] >> x & 1) joints_of[x][njoints_of[x]++] = a;
    int size = 0, c = 0;
    unsigned long full = 1ul << n;
    for (unsigned long i = 1; i < full; i++) {
        int x = __builtin_ctzl(i);              /* Gray code: toggle link x */
        unsigned long g = i ^ (i >> 1);
        int in = (g >> x) & 1;
        size += in ? 1 : -1;
        for (int k = 0; k < njoints_of[x]; k++) {
            int a = joints_of[x][k];
            if (in) { if (cnt[a]++ >= 1) c++; }
            else { if (--cnt[a] >= 1) c--; }
        }
        if (size >= 2 && size < n && 3 * (size - 1) - 2 * c <= 0) return 1;
    }
    return 0;
}

int main(int argc, char **argv) {
    if (argc != 3) { fprintf(stderr, "usage: chainfilter N M\n"); return 2; }
    n = atoi(argv[1]); m = atoi(argv[2]);
    static char line[4096];
    long kept = 0;
    while (fgets(line, sizeof line, stdin)) {
        const unsigned char *s = (const unsigned char *)line;
        int N = s[0] - 63;
        const unsigned char *body = s + 1;
        nj = 0;
        if (m == 0) {                           /* geng: upper triangle, column by column */
            long k = 0;
            for (int j = 1; j < N; j++)
                for (int i = 0; i < j; i++, k++)
                    if (bit(body, k)) jmask[nj++] = (1u << i) | (1u << j);
        } else {
            for (int a = 0; a < m; a++) {
                int j = n + a;
                unsigned mask = 0;
                for (int i = 0; i < n; i++)
                    if (bit(body, (long)j * (j - 1) / 2 + i)) mask |= 1u << i;
                jmask[nj++] = mask;
            }
        }
        (void)N;
        kept += !degenerate();
    }
    printf("%ld\n", kept);
    return 0;
}
