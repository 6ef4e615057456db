/* The benchmarks' statistics (tests/bench.h), against values worked out by hand: a median that is
 * wrong, or a paired ratio that pairs the wrong rounds, would print every issue-15 figure wrong. */
#include <string.h>

#include "bench.h"
#include "unit.h"

int main(void)
{
    double odd[5] = {5, 1, 4, 2, 3}, even[4] = {4, 1, 3, 2};
    CHECK_NEAR("median of 5", bench_median(odd, 5), 3.0, 0.0);
    CHECK_NEAR("median of 4: mean of the middle two", bench_median(even, 4), 2.5, 0.0);

    double q[5] = {50, 10, 40, 20, 30}, lo, hi;
    bench_quartiles(q, 5, &lo, &hi);
    CHECK("quartiles of 5: the 2nd and the 4th sorted", lo == 20 && hi == 40);
    double q15[15];
    for (int i = 0; i < 15; i++)
        q15[i] = 15 - i; /* 15 .. 1 */
    bench_quartiles(q15, 15, &lo, &hi);
    CHECK("quartiles of 15: the 4th and the 12th sorted", lo == 4 && hi == 12);

    /* Round i's ratio num[i] / den[i]: 2, 3, 2, 3, 5 -> median 3, quartiles 2 and 3. The medians' ratio
     * (5 / 2 = 2.5) mixes rounds, which is what the paired ratio is for. */
    double num[5] = {2, 9, 4, 12, 5}, den[5] = {1, 3, 2, 4, 1};
    double num0[5], den0[5];
    memcpy(num0, num, sizeof num);
    memcpy(den0, den, sizeof den);
    double r = bench_paired_ratio(num, den, 5, &lo, &hi);
    CHECK_NEAR("paired ratio: the median of the rounds' ratios", r, 3.0, 0.0);
    CHECK("paired ratio: the rounds' quartiles", lo == 2 && hi == 3);
    CHECK("paired ratio: the rounds are left in their order (the medians taken after it pair nothing wrong)",
          !memcmp(num, num0, sizeof num) && !memcmp(den, den0, sizeof den));
    /* Drift: every time of the fifth round doubled, the ratio of that round unchanged. */
    double slow_num[5] = {3, 3, 3, 3, 6}, slow_den[5] = {2, 2, 2, 2, 4};
    CHECK_NEAR("paired ratio: a round that ran slower as a whole changes nothing",
               bench_paired_ratio(slow_num, slow_den, 5, &lo, &hi), 1.5, 0.0);
    return unit_exit();
}
