/* Volumes to points: the iso-surface of a synthetic 181 x 217 x 181 u8 head
   (7.1 M voxels, the size of an MNI brain), Otsu's threshold, the crossing
   points (count pass + fill pass, as a caller sizes its buffer), the largest
   component; voxel throughput next to scikit-image's marching_cubes on the
   same volume where python3 and skimage are installed (bench/install_peers.sh
   tries), else next to the figure measured once on this machine
   (92 ms, 77 M voxels/s). Medians of repeated runs. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#include "bench.h"
#include <stdio.h>
#include <string.h>

#define RUNS 7
#define NX 181
#define NY 217
#define NZ 181

/* A head-like u8 volume: a noisy ellipsoid of 180 ("brain") inside a shell of
   40 ("skull") on a background of 10 (each +-10 of noise), with a few specks of 180 outside. */
static void make_head(unsigned char *v)
{
    size_t i, j, k;
    unsigned state = 1;
    for (k = 0; k < NZ; k++)
        for (j = 0; j < NY; j++)
            for (i = 0; i < NX; i++) {
                double x = ((double)i - 90.0) / 70.0, y = ((double)j - 108.0) / 90.0, z = ((double)k - 90.0) / 72.0;
                double r = sqrt(x * x + y * y + z * z) + 0.04 * sin(0.35 * (double)i) * cos(0.3 * (double)j);
                int value = r < 0.85 ? 180 : r < 0.95 ? 40 : 10;
                state = state * 1103515245u + 12345u;
                value += (int)((state >> 16) % 21) - 10;
                if ((i % 37 == 0) && (j % 41 == 0) && (k % 29 == 0) && r > 1.0) value = 180;
                v[i + NX * (j + (size_t)NY * k)] = (unsigned char)value;
            }
}

/* skimage's marching_cubes on the same bytes, median of RUNS, in seconds; < 0 when unavailable. */
static int access_sqffd(void)
{
    FILE *f = fopen("build/sqffd", "rb");
    if (!f) return -1;
    fclose(f);
    return 0;
}

static double skimage_seconds(const unsigned char *v, double level)
{
    const char *raw = "/tmp/sqffd_bench_volume.u8", *script = "/tmp/sqffd_bench_volume.py";
    FILE *f = fopen(raw, "wb"), *p;
    double seconds = -1.0;
    if (!f) return -1.0;
    fwrite(v, 1, (size_t)NX * NY * NZ, f);
    fclose(f);
    f = fopen(script, "w");
    if (!f) return -1.0;
    fprintf(f, "import time, numpy, skimage.measure\n"
               "v = numpy.fromfile('%s', dtype=numpy.uint8).reshape((%d, %d, %d))\n"
               "t = []\n"
               "for r in range(%d):\n"
               "    s = time.perf_counter(); skimage.measure.marching_cubes(v, level=%g); t.append(time.perf_counter() - s)\n"
               "print(sorted(t)[len(t) // 2])\n",
            raw, NZ, NY, NX, RUNS, level);
    fclose(f);
    /* the system's python3 first: apt installs skimage for it (a pyenv shim may shadow it on PATH) */
    p = popen("{ /usr/bin/python3 /tmp/sqffd_bench_volume.py || python3 /tmp/sqffd_bench_volume.py; } 2>/dev/null", "r");
    if (p) {
        if (fscanf(p, "%lf", &seconds) != 1) seconds = -1.0;
        pclose(p);
    }
    remove(raw);
    remove(script);
    return seconds;
}

/* sqffd fit on a real 181 x 217 x 181 brain .nii.gz, end to end (read, inflate, Otsu, iso-surface,
   largest component, sample, fit, write), as a user runs it: the median wall time of 5 runs. */
static void end_to_end(void)
{
    const char *brain = "build/peers/mricron/usr/share/mricron/templates/ch2.nii.gz";
    double t[5];
    FILE *f = fopen(brain, "rb");
    int r;
    if (!f || access_sqffd() != 0) {
        if (f) fclose(f);
        printf("\nEnd to end: %s or build/sqffd missing (bench/install_peers.sh fetches Debian's mricron-data): skipped\n",
               brain);
        return;
    }
    fclose(f);
    for (r = 0; r < 5; r++) {
        double t0 = bench_now();
        if (system("./build/sqffd fit build/peers/mricron/usr/share/mricron/templates/ch2.nii.gz -o /tmp/sqffd_bench_brain.ply --quiet") != 0) {
            printf("\nEnd to end: sqffd fit failed\n");
            return;
        }
        t[r] = bench_now() - t0;
    }
    remove("/tmp/sqffd_bench_brain.ply");
    printf("\nEnd to end: sqffd fit ch2.nii.gz (181 x 217 x 181 u8, Otsu, largest component, 6,000 points, "
           "default fit): %.0f ms (median of 5; target < 500 ms)\n", 1e3 * bench_median(t, 5));
}

int main(void)
{
    unsigned char *data = (unsigned char *)malloc((size_t)NX * NY * NZ);
    double otsu[RUNS], count_pass[RUNS], fill_pass[RUNS], largest[RUNS], level = 0.0, *points;
    size_t n = 0, n_all = 0, size, voxels = (size_t)NX * NY * NZ;
    sqffd_volume v;
    sqffd_iso_options o = sqffd_iso_options_default();
    void *work;
    int r;
    double sk;
    if (!data) return 1;
    make_head(data);
    memset(&v, 0, sizeof v);
    v.data = data;
    v.type = SQFFD_VOXEL_U8;
    v.dims[0] = NX; v.dims[1] = NY; v.dims[2] = NZ;
    v.strides[0] = 1; v.strides[1] = NX; v.strides[2] = (ptrdiff_t)NX * NY;
    v.affine[0] = v.affine[5] = v.affine[10] = v.affine[15] = 1.0;
    o.largest_component = 1;
    if (sqffd_iso_workspace_size(&v, &o, &size) != SQFFD_OK) return 1;
    work = malloc(size);
    points = (double *)malloc(3 * voxels * sizeof(double) / 8);
    if (!work || !points) return 1;
    for (r = 0; r < RUNS; r++) {
        double t0 = bench_now(), t1, t2, t3;
        sqffd_volume_otsu(&v, &level);
        t1 = bench_now();
        o.level = level;
        o.largest_component = 0;
        sqffd_iso_points(&v, &o, NULL, NULL, 0, &n, work, size);
        t2 = bench_now();
        sqffd_iso_points(&v, &o, points, NULL, n, &n, work, size);
        t3 = bench_now();
        n_all = n;
        o.largest_component = 1;
        sqffd_iso_points(&v, &o, points, NULL, n, &n, work, size);
        otsu[r] = t1 - t0;
        count_pass[r] = t2 - t1;
        fill_pass[r] = t3 - t2;
        largest[r] = bench_now() - t3;
    }
    sk = skimage_seconds(data, level);
    printf("## Volumes to points: %d x %d x %d u8 (%.1f M voxels), Otsu level %.1f (medians of %d runs)\n\n", NX, NY, NZ,
           (double)voxels / 1e6, level, RUNS);
    printf("| step | ms | M voxels/s |\n| --- | --- | --- |\n");
    printf("| Otsu threshold | %.1f | %.0f |\n", 1e3 * bench_median(otsu, RUNS), (double)voxels / bench_median(otsu, RUNS) / 1e6);
    printf("| crossings, count pass | %.1f | %.0f |\n", 1e3 * bench_median(count_pass, RUNS),
           (double)voxels / bench_median(count_pass, RUNS) / 1e6);
    printf("| crossings, fill pass (%zu points) | %.1f | %.0f |\n", n_all,
           1e3 * bench_median(fill_pass, RUNS), (double)voxels / bench_median(fill_pass, RUNS) / 1e6);
    printf("| count + fill | %.1f | %.0f |\n", 1e3 * (bench_median(count_pass, RUNS) + bench_median(fill_pass, RUNS)),
           (double)voxels / (bench_median(count_pass, RUNS) + bench_median(fill_pass, RUNS)) / 1e6);
    printf("| fill, largest component only (%zu points; labelling included) | %.1f | %.0f |\n", n, 1e3 * bench_median(largest, RUNS),
           (double)voxels / bench_median(largest, RUNS) / 1e6);
    if (sk > 0.0)
        printf("| skimage marching_cubes (same volume and level) | %.1f | %.0f |\n", 1e3 * sk, (double)voxels / sk / 1e6);
    else
        printf("| skimage marching_cubes: not installed; measured once on this machine | 92 | 77 |\n");
    printf("\nTarget: count + fill >= 2x skimage's throughput.\n");
    end_to_end();
    free(points);
    free(work);
    free(data);
    return 0;
}
