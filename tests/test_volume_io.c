/* suite_volume_io: the NIfTI-1, MetaImage and NRRD readers of examples/sqffd_image.h.

   Ground truth:
   - the real NIfTI files in tests/data: every expected number below was
     written down from nibabel 5.0.0 (Debian python3-nibabel; img.affine,
     np.asanyarray(img.dataobj)[i, j, k]) and the raw header fields from an
     independent decode with Python's struct module;
   - the hand-made files: built here byte by byte by encoders independent of
     the reader, from the value formula voxel_value(); the synthetic NIfTI
     affines (qform, pixdim fall-back) were computed by nibabel 5.0.0 from
     the same header fields (Nifti1Header.from_fileobj + get_best_affine);
     MetaImage and NRRD geometry is worked out by hand from the formats'
     definitions (MetaIO: TransformMatrix holds each voxel axis's direction
     as three consecutive numbers, ITK's direction matrix transposed; NRRD:
     "space directions" are the columns, "space origin" the translation);
   - the compressed streams: made with Python 3's zlib 1.2.13 (level 9;
     gzip.compress(..., mtime=0)) from the same formula, bytes embedded below. */
#include "test.h"
#include "test_bytes.h"
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_image.h"

/* ---- a growing byte buffer ------------------------------------------------ */


/* ---- voxel values: one formula per type, and an encoder ------------------- */

static const sqffd_voxel_type all_types[7] = {SQFFD_VOXEL_U8,  SQFFD_VOXEL_I8,  SQFFD_VOXEL_U16, SQFFD_VOXEL_I16,
                                              SQFFD_VOXEL_I32, SQFFD_VOXEL_F32, SQFFD_VOXEL_F64};
static const size_t type_size[7] = {1, 1, 2, 2, 4, 4, 8};

/* The value stored at (i, j, k, t) of a hand-made image of `type`: chosen to
   use each type's range (values over 127 in uint8, negatives, over 32767 in
   uint16...), exact in the type. */
static double voxel_value(sqffd_voxel_type type, size_t i, size_t j, size_t k, size_t t)
{
    double n = (double)(i + 10 * j + 100 * k + 1000 * t), small = (double)(i + 4 * j + 12 * k + 24 * t);
    switch (type) {
    case SQFFD_VOXEL_U8: return 200 + small;
    case SQFFD_VOXEL_I8: return small - 100;
    case SQFFD_VOXEL_U16: return 60000 + n;
    case SQFFD_VOXEL_I16: return n - 50;
    case SQFFD_VOXEL_I32: return n * 100000 - 70000;
    case SQFFD_VOXEL_F32: return n * 0.5 - 3.25;
    default: return n * 0.1 - 1.0 / 3.0;
    }
}

/* Appends `value` as `type` in the given byte order. */
static void put_voxel(bytes *b, sqffd_voxel_type type, double value, int big_endian)
{
    unsigned char raw[8], out[8];
    size_t n = type_size[type], i;
    switch (type) {
    case SQFFD_VOXEL_U8: raw[0] = (unsigned char)value; break;
    case SQFFD_VOXEL_I8: { int8_t v = (int8_t)value; memcpy(raw, &v, 1); break; }
    case SQFFD_VOXEL_U16: { uint16_t v = (uint16_t)value; raw[0] = (unsigned char)(v & 0xff); raw[1] = (unsigned char)(v >> 8); break; }
    case SQFFD_VOXEL_I16: { uint16_t v = (uint16_t)(int16_t)value; raw[0] = (unsigned char)(v & 0xff); raw[1] = (unsigned char)(v >> 8); break; }
    case SQFFD_VOXEL_I32: {
        uint32_t v = (uint32_t)(int32_t)value;
        for (i = 0; i < 4; i++) raw[i] = (unsigned char)(v >> (8 * i));
        break;
    }
    case SQFFD_VOXEL_F32: {
        float f = (float)value;
        uint32_t v;
        memcpy(&v, &f, 4);
        for (i = 0; i < 4; i++) raw[i] = (unsigned char)(v >> (8 * i));
        break;
    }
    default: {
        uint64_t v;
        memcpy(&v, &value, 8);
        for (i = 0; i < 8; i++) raw[i] = (unsigned char)(v >> (8 * i));
        break;
    }
    }
    /* raw is little-endian here */
    for (i = 0; i < n; i++) out[i] = big_endian ? raw[n - 1 - i] : raw[i];
    bytes_put(b, out, n);
}

/* Appends the voxels of an nx x ny x nz x nt image, first index fastest. */
static void put_voxels(bytes *b, sqffd_voxel_type type, size_t nx, size_t ny, size_t nz, size_t nt, int big_endian)
{
    size_t i, j, k, t;
    for (t = 0; t < nt; t++)
        for (k = 0; k < nz; k++)
            for (j = 0; j < ny; j++)
                for (i = 0; i < nx; i++) put_voxel(b, type, voxel_value(type, i, j, k, t), big_endian);
}

/* The stored value of voxel (i, j, k) of a view, read the way the core's
   contract describes (data + i strides[0] + ...), native order. */
static double read_voxel(const sqffd_volume *v, size_t i, size_t j, size_t k)
{
    const char *p = (const char *)v->data + (ptrdiff_t)i * v->strides[0] + (ptrdiff_t)j * v->strides[1] +
                    (ptrdiff_t)k * v->strides[2];
    switch (v->type) {
    case SQFFD_VOXEL_U8: return *(const unsigned char *)p;
    case SQFFD_VOXEL_I8: { int8_t x; memcpy(&x, p, 1); return x; }
    case SQFFD_VOXEL_U16: { uint16_t x; memcpy(&x, p, 2); return x; }
    case SQFFD_VOXEL_I16: { int16_t x; memcpy(&x, p, 2); return x; }
    case SQFFD_VOXEL_I32: { int32_t x; memcpy(&x, p, 4); return x; }
    case SQFFD_VOXEL_F32: { float x; memcpy(&x, p, 4); return x; }
    default: { double x; memcpy(&x, p, 8); return x; }
    }
}

/* Every voxel of every frame against voxel_value(); the count of mismatches. */
static int count_wrong_voxels(const sqffd_image *im, sqffd_voxel_type type)
{
    size_t i, j, k, t;
    int wrong = 0;
    for (t = 0; t < im->frames; t++) {
        sqffd_volume f = sqffd_image_frame(im, t);
        for (k = 0; k < f.dims[2]; k++)
            for (j = 0; j < f.dims[1]; j++)
                for (i = 0; i < f.dims[0]; i++) {
                    double expected = voxel_value(type, i, j, k, t);
                    if (type == SQFFD_VOXEL_F32) expected = (double)(float)expected;
                    if (read_voxel(&f, i, j, k) != expected) wrong++;
                }
    }
    return wrong;
}

static void check_affine(const sqffd_image *im, const double expected[12], double tol, int line)
{
    int a;
    for (a = 0; a < 12; a++)
        if (!(fabs(im->volume.affine[a] - expected[a]) <= tol))
            test_fail(__FILE__, line, "affine[%d] = %.17g, expected %.17g", a, im->volume.affine[a], expected[a]);
    if (im->volume.affine[12] != 0 || im->volume.affine[13] != 0 || im->volume.affine[14] != 0 ||
        im->volume.affine[15] != 1)
        test_fail(__FILE__, line, "affine's last row is not 0 0 0 1");
}
#define CHECK_AFFINE(im, expected, tol) check_affine(im, expected, tol, __LINE__)

static void check_dims(const sqffd_image *im, size_t nx, size_t ny, size_t nz, size_t frames, int line)
{
    if (im->volume.dims[0] != nx || im->volume.dims[1] != ny || im->volume.dims[2] != nz || im->frames != frames)
        test_fail(__FILE__, line, "dims %zu x %zu x %zu x %zu, expected %zu x %zu x %zu x %zu", im->volume.dims[0],
                  im->volume.dims[1], im->volume.dims[2], im->frames, nx, ny, nz, frames);
}
#define CHECK_DIMS(im, nx, ny, nz, frames) check_dims(im, nx, ny, nz, frames, __LINE__)

/* Whether a failure left the image empty and wrote "NAME: <expected part>". */
static void check_failure(int r, const sqffd_image *im, const char *err, const char *name, const char *part, int line)
{
    size_t n = strlen(name);
    if (r == 0) { test_fail(__FILE__, line, "%s: read succeeded, expected \"%s\"", name, part); return; }
    if (im->buffer || im->volume.data || im->frames)
        test_fail(__FILE__, line, "%s: a failed read left memory or views in the image", name);
    if (strncmp(err, name, n) != 0 || strncmp(err + n, ": ", 2) != 0)
        test_fail(__FILE__, line, "message \"%s\" does not start with \"%s: \"", err, name);
    if (!strstr(err, part)) test_fail(__FILE__, line, "message \"%s\" lacks \"%s\"", err, part);
}
#define CHECK_FAILS(call, im, err, name, part) check_failure((call), im, err, name, part, __LINE__)

/* Whether b, read from memory as name, holds the voxels of type; b is freed. */
static void check_reads(bytes *b, const char *name, sqffd_voxel_type type, int line)
{
    sqffd_image im;
    char err[256] = "";
    if (sqffd_image_read_memory(b->data, b->size, name, &im, err, sizeof err) != 0) {
        test_fail(__FILE__, line, "%s", err);
    } else {
        if (count_wrong_voxels(&im, type) != 0) test_fail(__FILE__, line, "%s: voxel values wrong", name);
        sqffd_image_free(&im);
    }
    bytes_free(b);
}
#define CHECK_READS(b, name, type) check_reads(b, name, type, __LINE__)

/* Writes a file for the detached-data tests (in the working directory, like
   test_io's writer test); 0 when it cannot. */
static int write_file(const char *path, const void *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    size_t done;
    if (!f) return 0;
    done = fwrite(data, 1, size, f);
    return fclose(f) == 0 && done == size;
}

/* ---- the real NIfTI files ------------------------------------------------- */

/* Sums every stored value of every frame (int16 images). */
static long long sum_i16(const sqffd_image *im)
{
    long long sum = 0;
    size_t i, j, k, t;
    for (t = 0; t < im->frames; t++) {
        sqffd_volume f = sqffd_image_frame(im, t);
        for (k = 0; k < f.dims[2]; k++)
            for (j = 0; j < f.dims[1]; j++)
                for (i = 0; i < f.dims[0]; i++) sum += (long long)read_voxel(&f, i, j, k);
    }
    return sum;
}

/* anatomical.nii: big-endian int16, sform code 2. Header fields from struct:
   dim (3, 33, 41, 25), datatype 4, pixdim (-1, 2, 2, 2), vox_offset 352,
   scl_slope 1.0, scl_inter 0.0 (nibabel prints NaN: it moves the scaling to
   the image object), qform_code 2, sform_code 2. Affine and voxels: nibabel. */
static void test_volume_io_nifti_anatomical(void)
{
    static const double affine[12] = {-2, 0, 0, 32, 0, 2, 0, -40, 0, 0, 2, -16};
    sqffd_image im;
    char err[256] = "";
    CHECK_MSG(sqffd_image_read_file("tests/data/anatomical.nii", &im, err, sizeof err) == 0, "%s", err);
    if (!im.buffer) return;
    CHECK(strcmp(im.format, "NIfTI-1") == 0);
    CHECK(strcmp(im.stored_type, "int16") == 0 && im.volume.type == SQFFD_VOXEL_I16);
    CHECK(im.big_endian == 1);
    CHECK_DIMS(&im, 33, 41, 25, 1);
    CHECK(im.volume.strides[0] == 2 && im.volume.strides[1] == 66 && im.volume.strides[2] == 2706);
    CHECK(im.spacing[0] == 2 && im.spacing[1] == 2 && im.spacing[2] == 2 && im.time_step == 0);
    CHECK(strcmp(im.affine_source, "sform") == 0);
    CHECK_AFFINE(&im, affine, 1e-6);
    CHECK(im.volume.scale == 1 && im.volume.offset == 0);
    CHECK(read_voxel(&im.volume, 0, 0, 0) == 10712);
    CHECK(read_voxel(&im.volume, 16, 20, 12) == 11881);
    CHECK(read_voxel(&im.volume, 32, 40, 24) == 2971);
    CHECK(read_voxel(&im.volume, 5, 30, 20) == 9110);
    CHECK(read_voxel(&im.volume, 20, 10, 3) == 10931);
    CHECK(read_voxel(&im.volume, 1, 2, 3) == 9798);
    CHECK(read_voxel(&im.volume, 17, 23, 0) == 30393);  /* the maximum */
    CHECK(read_voxel(&im.volume, 24, 32, 14) == -610);  /* the minimum: the sign survives the swap */
    CHECK(sum_i16(&im) == 284166082LL);
    sqffd_image_free(&im);
    CHECK(im.buffer == NULL && im.volume.data == NULL);
}

/* KmeansTest_T1UCharRaw.nii.gz: gzip, little-endian int16, sform code 1
   (qform code 2 ignored, as nibabel does); dim[4..7] are 0 (ignored: dim[0]
   is 3). struct: pixdim (1, 2, 2, 3), vox_offset 352. */
static void test_volume_io_nifti_kmeans_gz(void)
{
    static const double affine[12] = {-2, 0, 0, 0, 0, 0, 3, -254, 0, 2, 0, 0};
    sqffd_image im, mem;
    char err[256] = "";
    FILE *f;
    unsigned char *file;
    long size;
    CHECK_MSG(sqffd_image_read_file("tests/data/KmeansTest_T1UCharRaw.nii.gz", &im, err, sizeof err) == 0, "%s", err);
    if (!im.buffer) return;
    CHECK(strcmp(im.stored_type, "int16") == 0 && im.big_endian == 0);
    CHECK_DIMS(&im, 128, 128, 62, 1);
    CHECK(im.spacing[0] == 2 && im.spacing[1] == 2 && im.spacing[2] == 3);
    CHECK(strcmp(im.affine_source, "sform") == 0);
    CHECK_AFFINE(&im, affine, 1e-6);
    CHECK(read_voxel(&im.volume, 64, 64, 31) == 97);
    CHECK(read_voxel(&im.volume, 40, 80, 20) == 67);
    CHECK(read_voxel(&im.volume, 50, 70, 15) == 96);
    CHECK(read_voxel(&im.volume, 90, 40, 40) == 74);
    CHECK(read_voxel(&im.volume, 70, 30, 10) == 9);
    CHECK(read_voxel(&im.volume, 30, 44, 47) == 255);
    CHECK(read_voxel(&im.volume, 127, 127, 61) == 0);
    CHECK(sum_i16(&im) == 19533798LL);

    /* the same bytes through sqffd_image_read_memory: the same image */
    f = fopen("tests/data/KmeansTest_T1UCharRaw.nii.gz", "rb");
    CHECK(f != NULL);
    if (!f) { sqffd_image_free(&im); return; }
    fseek(f, 0, SEEK_END);
    size = ftell(f);
    fseek(f, 0, SEEK_SET);
    file = (unsigned char *)malloc((size_t)size);
    CHECK(fread(file, 1, (size_t)size, f) == (size_t)size);
    fclose(f);
    CHECK_MSG(sqffd_image_read_memory(file, (size_t)size, "k.nii.gz", &mem, err, sizeof err) == 0, "%s", err);
    if (mem.buffer) {
        CHECK(memcmp(mem.buffer, im.buffer, 128 * 128 * 62 * 2) == 0);
        CHECK(memcmp(mem.volume.affine, im.volume.affine, sizeof im.volume.affine) == 0);
        sqffd_image_free(&mem);
    }
    /* cut inside the gzip stream: the inflater's message, named */
    CHECK_FAILS(sqffd_image_read_memory(file, (size_t)size / 2, "k.nii.gz", &mem, err, sizeof err), &mem, err,
                "k.nii.gz", "gzip");
    free(file);
    sqffd_image_free(&im);
}

/* example4d.nii.gz: 4-D int16, two frames, a header extension (vox_offset
   416), sform code 1, pixdim[4] = 2000 (ms). struct: dim (4, 128, 96, 24, 2). */
static void test_volume_io_nifti_example4d(void)
{
    static const double affine[12] = {-2.0, 6.7147156535937462e-19, 9.0810245110817154e-18, 117.8551025390625,
                                      -6.7147156535937462e-19, 1.9737114906311035, -0.35552823543548584,
                                      -35.722942352294922, 8.2554808889609302e-18, 0.32320761680603027,
                                      2.1710817813873291, -7.2487983703613281};
    sqffd_image im;
    sqffd_volume f0, f1, none;
    char err[256] = "";
    CHECK_MSG(sqffd_image_read_file("tests/data/example4d.nii.gz", &im, err, sizeof err) == 0, "%s", err);
    if (!im.buffer) return;
    CHECK_DIMS(&im, 128, 96, 24, 2);
    CHECK(im.frame_stride == 128 * 96 * 24 * 2);
    CHECK(im.spacing[0] == 2 && im.spacing[1] == 2 && fabs(im.spacing[2] - 2.1999990940093994) < 1e-12);
    CHECK(im.time_step == 2000);
    CHECK(strcmp(im.affine_source, "sform") == 0);
    CHECK_AFFINE(&im, affine, 1e-6);
    f0 = sqffd_image_frame(&im, 0);
    f1 = sqffd_image_frame(&im, 1);
    none = sqffd_image_frame(&im, 2);
    CHECK(f0.data == im.volume.data && (const char *)f1.data == (const char *)f0.data + im.frame_stride);
    CHECK(none.data == NULL && none.dims[0] == 0);
    CHECK(read_voxel(&f0, 64, 48, 12) == 265);
    CHECK(read_voxel(&f1, 64, 48, 12) == 266);
    CHECK(read_voxel(&f1, 70, 30, 10) == 437);
    CHECK(read_voxel(&f0, 50, 70, 15) == 481);
    CHECK(read_voxel(&f1, 90, 40, 20) == 700);
    CHECK(read_voxel(&f0, 64, 49, 0) == 1162);
    CHECK(read_voxel(&f1, 127, 95, 23) == 0);
    CHECK(sum_i16(&im) == 101985356LL);
    sqffd_image_free(&im);
}

/* ---- hand-made NIfTI-1 ---------------------------------------------------- */

/* The NIfTI-1 header fields the tests set (nifti1.h layout). */
typedef struct nifti_fields {
    int big_endian;
    int16_t dim[8], datatype, qform_code, sform_code;
    float pixdim[8], vox_offset, slope, inter, quatern[3], qoffset[3], srow[12];
    char magic[4];
    int extension; /* the byte at 348 */
} nifti_fields;

static void put_at(unsigned char *h, size_t at, const void *value, size_t n, int big_endian)
{
    size_t i;
    const unsigned char *v = (const unsigned char *)value;
    int native_big = 0;
    uint16_t one = 1;
    memcpy(&native_big, &one, 1);
    native_big = !native_big;
    for (i = 0; i < n; i++) h[at + i] = v[big_endian == native_big ? i : n - 1 - i];
}

/* A 352-byte header (with the 4 extension bytes) from the fields. */
static void nifti_header(bytes *b, const nifti_fields *f)
{
    unsigned char h[352];
    int32_t sizeof_hdr = 348;
    int a;
    memset(h, 0, sizeof h);
    put_at(h, 0, &sizeof_hdr, 4, f->big_endian);
    for (a = 0; a < 8; a++) put_at(h, 40 + 2 * (size_t)a, &f->dim[a], 2, f->big_endian);
    put_at(h, 70, &f->datatype, 2, f->big_endian);
    for (a = 0; a < 8; a++) put_at(h, 76 + 4 * (size_t)a, &f->pixdim[a], 4, f->big_endian);
    put_at(h, 108, &f->vox_offset, 4, f->big_endian);
    put_at(h, 112, &f->slope, 4, f->big_endian);
    put_at(h, 116, &f->inter, 4, f->big_endian);
    put_at(h, 252, &f->qform_code, 2, f->big_endian);
    put_at(h, 254, &f->sform_code, 2, f->big_endian);
    for (a = 0; a < 3; a++) put_at(h, 256 + 4 * (size_t)a, &f->quatern[a], 4, f->big_endian);
    for (a = 0; a < 3; a++) put_at(h, 268 + 4 * (size_t)a, &f->qoffset[a], 4, f->big_endian);
    for (a = 0; a < 12; a++) put_at(h, 280 + 4 * (size_t)a, &f->srow[a], 4, f->big_endian);
    memcpy(h + 344, f->magic, 4);
    h[348] = (unsigned char)f->extension;
    bytes_put(b, h, sizeof h);
}

static const int16_t nifti_codes[7] = {2, 256, 512, 4, 8, 16, 64}; /* all_types' order */
static const char *const nifti_names[7] = {"uint8", "int8", "uint16", "int16", "int32", "float32", "float64"};

/* A 4 x 3 x 2 image of `type` with a qform (the fields nibabel was given). */
static nifti_fields nifti_default(sqffd_voxel_type type, int big_endian)
{
    nifti_fields f;
    memset(&f, 0, sizeof f);
    f.big_endian = big_endian;
    f.dim[0] = 3; f.dim[1] = 4; f.dim[2] = 3; f.dim[3] = 2;
    f.dim[4] = f.dim[5] = f.dim[6] = f.dim[7] = 1;
    f.datatype = nifti_codes[type];
    f.pixdim[0] = -1; f.pixdim[1] = 1.5f; f.pixdim[2] = 2.0f; f.pixdim[3] = 2.5f;
    f.vox_offset = 352;
    f.qform_code = 1;
    f.quatern[0] = 0.1f; f.quatern[1] = 0.2f; f.quatern[2] = 0.3f;
    f.qoffset[0] = 10; f.qoffset[1] = -20; f.qoffset[2] = 30;
    memcpy(f.magic, "n+1", 4);
    return f;
}

static void nifti_file(bytes *b, const nifti_fields *f, sqffd_voxel_type type)
{
    nifti_header(b, f);
    put_voxels(b, type, (size_t)f->dim[1], (size_t)f->dim[2], (size_t)f->dim[3], f->dim[0] >= 4 ? (size_t)f->dim[4] : 1,
               f->big_endian);
}

/* Every datatype in both byte orders; the qform (nibabel's numbers) and the
   scaling fields. */
static void test_volume_io_nifti_types_and_qform(void)
{
    /* nibabel 5.0.0, get_best_affine() of these fields: quatern (0.1, 0.2, 0.3),
       pixdim (-1, 1.5, 2, 2.5), qoffset (10, -20, 30) */
    static const double qform[12] = {1.1099999749660487,  -1.0328342557035766, -1.07736186690416,   10,
                                     0.8946256953539611,  1.599999970197677,   0.16368091296298318, -20,
                                     -0.4664171103077296, 0.6109447565964305,  -2.2499999925494194, 30};
    int t, order;
    for (t = 0; t < 7; t++)
        for (order = 0; order < 2; order++) {
            sqffd_voxel_type type = all_types[t];
            nifti_fields f = nifti_default(type, order);
            bytes b = {NULL, 0, 0};
            sqffd_image im;
            char err[256] = "";
            f.slope = 2;
            f.inter = -3;
            nifti_file(&b, &f, type);
            CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "t.nii", &im, err, sizeof err) == 0, "%s", err);
            if (im.buffer) {
                CHECK_MSG(im.volume.type == type && strcmp(im.stored_type, nifti_names[t]) == 0, "%s",
                          im.stored_type);
                CHECK(im.big_endian == order);
                CHECK_DIMS(&im, 4, 3, 2, 1);
                CHECK(im.volume.strides[0] == (ptrdiff_t)type_size[t] &&
                      im.volume.strides[1] == (ptrdiff_t)(4 * type_size[t]) &&
                      im.volume.strides[2] == (ptrdiff_t)(12 * type_size[t]));
                CHECK_MSG(count_wrong_voxels(&im, type) == 0, "%s, %s-endian", nifti_names[t], order ? "big" : "little");
                CHECK(strcmp(im.affine_source, "qform") == 0);
                CHECK_AFFINE(&im, qform, 1e-6);
                CHECK(im.volume.scale == 2 && im.volume.offset == -3);
                CHECK(im.spacing[0] == 1.5 && im.spacing[1] == 2 && im.spacing[2] == 2.5);
                sqffd_image_free(&im);
            }
            bytes_free(&b);
        }
}

/* The other affine sources and the scaling rules. */
static void test_volume_io_nifti_affine_sources(void)
{
    /* nibabel 5.0.0: both codes 0 -> the base affine, x flipped, centred:
       pixdim (1, 1.5, 2, 2.5), dims 4 x 3 x 2 */
    static const double fallback[12] = {-1.5, 0, 0, 2.25, 0, 2, 0, -2, 0, 0, 2.5, -1.25};
    /* nibabel 5.0.0: pixdim[0] = 0 is read as qfac 1 (column 3 not negated) */
    static const double qfac_one[12] = {1.1099999749660487,  -1.0328342557035766, 1.07736186690416,     10,
                                        0.8946256953539611,  1.599999970197677,   -0.16368091296298318, -20,
                                        -0.4664171103077296, 0.6109447565964305,  2.2499999925494194,   30};
    static const double sform[12] = {0, -2, 0, 10, 1.5, 0, 0, -20, 0, 0, 2.5, 30};
    nifti_fields f;
    bytes b = {NULL, 0, 0};
    sqffd_image im;
    char err[256] = "";
    int a;

    f = nifti_default(SQFFD_VOXEL_F32, 1);
    f.qform_code = 0;
    f.pixdim[0] = 1;
    f.slope = NAN; /* NaN slope: unscaled */
    f.inter = 5;
    nifti_file(&b, &f, SQFFD_VOXEL_F32);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "p.nii", &im, err, sizeof err) == 0, "%s", err);
    CHECK(strcmp(im.affine_source, "pixdim") == 0);
    CHECK_AFFINE(&im, fallback, 1e-12);
    CHECK(im.volume.scale == 0 && im.volume.offset == 0);
    sqffd_image_free(&im);
    bytes_free(&b);

    f = nifti_default(SQFFD_VOXEL_I16, 0);
    f.pixdim[0] = 0;
    f.slope = 0; /* zero slope: unscaled, whatever the intercept */
    f.inter = 7;
    nifti_file(&b, &f, SQFFD_VOXEL_I16);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "q.nii", &im, err, sizeof err) == 0, "%s", err);
    CHECK(strcmp(im.affine_source, "qform") == 0);
    CHECK_AFFINE(&im, qfac_one, 1e-6);
    CHECK(im.volume.scale == 0 && im.volume.offset == 0);
    sqffd_image_free(&im);
    bytes_free(&b);

    /* sform wins over the qform; srow rows are the affine's rows */
    f = nifti_default(SQFFD_VOXEL_I16, 1);
    f.sform_code = 2;
    for (a = 0; a < 12; a++) f.srow[a] = (float)sform[a];
    nifti_file(&b, &f, SQFFD_VOXEL_I16);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "s.nii", &im, err, sizeof err) == 0, "%s", err);
    CHECK(strcmp(im.affine_source, "sform") == 0);
    CHECK_AFFINE(&im, sform, 0);
    sqffd_image_free(&im);
    bytes_free(&b);

    /* 4-D with a unit 7th dimension: dim[0] = 7 is fine when dim[5..7] are 1 */
    f = nifti_default(SQFFD_VOXEL_I16, 0);
    f.dim[0] = 7;
    f.dim[4] = 2;
    f.pixdim[4] = 0.75f;
    nifti_file(&b, &f, SQFFD_VOXEL_I16);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "7.nii", &im, err, sizeof err) == 0, "%s", err);
    CHECK_DIMS(&im, 4, 3, 2, 2);
    CHECK(im.frame_stride == 48 && im.time_step == 0.75);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
    sqffd_image_free(&im);
    bytes_free(&b);

    /* vox_offset past 352 (an extension in between), and vox_offset 0 = 352 */
    f = nifti_default(SQFFD_VOXEL_U8, 0);
    f.vox_offset = 368;
    f.extension = 1;
    nifti_header(&b, &f);
    bytes_put(&b, "\x10\0\0\0\x06\0\0\0comment!", 16); /* esize 16, ecode 6 (comment), 8 bytes */
    put_voxels(&b, SQFFD_VOXEL_U8, 4, 3, 2, 1, 0);
    CHECK_READS(&b, "e.nii", SQFFD_VOXEL_U8);
    f = nifti_default(SQFFD_VOXEL_U8, 1);
    f.vox_offset = 0;
    nifti_file(&b, &f, SQFFD_VOXEL_U8);
    CHECK_READS(&b, "z.nii", SQFFD_VOXEL_U8);
}

/* A .hdr/.img pair on disk, named by either file; from memory it is refused. */
static void test_volume_io_nifti_pair(void)
{
    nifti_fields f = nifti_default(SQFFD_VOXEL_U16, 1);
    bytes hdr = {NULL, 0, 0}, img = {NULL, 0, 0};
    sqffd_image im;
    char err[256] = "";
    memcpy(f.magic, "ni1", 4);
    f.vox_offset = 8; /* the voxels start 8 bytes into the .img */
    nifti_header(&hdr, &f);
    bytes_put(&img, "12345678", 8);
    put_voxels(&img, SQFFD_VOXEL_U16, 4, 3, 2, 1, 1);
    if (!write_file("sqffd_test_pair.hdr", hdr.data, 348) || !write_file("sqffd_test_pair.img", img.data, img.size)) {
        printf("    (skipped: cannot write files in the working directory)\n");
        bytes_free(&hdr);
        bytes_free(&img);
        return;
    }
    CHECK_MSG(sqffd_image_read_file("sqffd_test_pair.hdr", &im, err, sizeof err) == 0, "%s", err);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_U16) == 0 && im.big_endian == 1);
    sqffd_image_free(&im);
    CHECK_MSG(sqffd_image_read_file("sqffd_test_pair.img", &im, err, sizeof err) == 0, "%s", err);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_U16) == 0);
    sqffd_image_free(&im);
    CHECK_FAILS(sqffd_image_read_memory(hdr.data, 348, "p.hdr", &im, err, sizeof err), &im, err, "p.hdr",
                "its voxels are in the .img");
    /* the .img one byte short */
    CHECK(write_file("sqffd_test_pair.img", img.data, img.size - 1));
    CHECK_FAILS(sqffd_image_read_file("sqffd_test_pair.hdr", &im, err, sizeof err), &im, err,
                "sqffd_test_pair.img", "data: the header promises 48 bytes from offset 8, the file holds 47");
    remove("sqffd_test_pair.hdr");
    remove("sqffd_test_pair.img");
    bytes_free(&hdr);
    bytes_free(&img);
}

/* Broken NIfTI files: each refused with the field named. */
static void test_volume_io_nifti_broken(void)
{
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0};
    nifti_fields f;

#define NIFTI_CASE(setup, part)                                                                   \
    do {                                                                                          \
        f = nifti_default(SQFFD_VOXEL_I16, 0);                                                    \
        setup;                                                                                    \
        nifti_header(&b, &f); /* then the voxels of the default 4 x 3 x 2, whatever dim says */  \
        put_voxels(&b, SQFFD_VOXEL_I16, 4, 3, 2, 1, 0);                                           \
        CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "b.nii", &im, err, sizeof err), &im, err, "b.nii", part); \
        bytes_free(&b);                                                                           \
    } while (0)

    NIFTI_CASE(memcpy(f.magic, "n+2", 4), "Analyze 7.5 (a .hdr without the NIfTI-1 magic) is not read by sqffd");
    NIFTI_CASE(memcpy(f.magic, "ni1", 4), "its voxels are in the .img"); /* the other magic, for contrast */
    { /* a format no reader takes, whatever the name says */
        unsigned char dicom[200];
        memset(dicom, 0, sizeof dicom);
        memcpy(dicom + 128, "DICM", 4);
        CHECK_FAILS(sqffd_image_read_memory(dicom, sizeof dicom, "scan.nii", &im, err, sizeof err), &im, err,
                    "scan.nii", "DICOM is not read by sqffd; convert it to NIfTI (e.g. with dcm2niix)");
    }
    NIFTI_CASE(f.dim[0] = 8, "dim[0] = 8: the number of dimensions must be 1 to 7");
    NIFTI_CASE((f.dim[0] = 7, f.dim[5] = 2), "dim[5] = 2: images of more than 4 dimensions are not supported");
    NIFTI_CASE(f.dim[2] = -3, "dim[2] = -3: must be at least 1");
    NIFTI_CASE(f.dim[3] = 0, "dim[3] = 0: must be at least 1");
    NIFTI_CASE((f.dim[0] = 4, f.dim[1] = f.dim[2] = f.dim[3] = f.dim[4] = 32767, f.datatype = 64),
               "32767 x 32767 x 32767 x 32767 voxels of 8 bytes: more than");
    NIFTI_CASE(f.datatype = 999, "datatype 999 is not a NIfTI-1 datatype code");
    NIFTI_CASE(f.datatype = 32, "datatype 32 (complex64) is not supported");
    NIFTI_CASE(f.datatype = 1024, "datatype 1024 (int64) is not supported");
    NIFTI_CASE(f.vox_offset = 100000, "data: they start at byte 100000, past the end of the file (400 bytes)");
    NIFTI_CASE(f.vox_offset = 100, "vox_offset = 100: inside the 352 bytes of header");
    NIFTI_CASE(f.vox_offset = 352.5f, "vox_offset = 352.5 is not a byte offset");
    NIFTI_CASE(f.vox_offset = -352, "vox_offset = -352 is not a byte offset");
    NIFTI_CASE(f.vox_offset = 354, "data: the header promises 48 bytes from offset 354, the file holds 46");
    NIFTI_CASE((f.slope = 2, f.inter = INFINITY), "scl_inter is not finite while scl_slope is 2");
    NIFTI_CASE(f.pixdim[2] = NAN, "pixdim[2] is not a finite number");
    NIFTI_CASE((f.sform_code = 1, f.srow[5] = INFINITY), "the sform holds a value that is not finite");
    NIFTI_CASE((f.vox_offset = 0, f.extension = 1), "vox_offset = 0 with header extensions present");
#undef NIFTI_CASE

    /* truncated header, truncated data, NIfTI-2, not NIfTI at all */
    f = nifti_default(SQFFD_VOXEL_I16, 1);
    nifti_file(&b, &f, SQFFD_VOXEL_I16);
    CHECK_FAILS(sqffd_image_read_memory(b.data, 200, "h.nii", &im, err, sizeof err), &im, err, "h.nii",
                "truncated header: 200 bytes, a NIfTI-1 header has 348");
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size - 1, "d.nii", &im, err, sizeof err), &im, err, "d.nii",
                "data: the header promises 48 bytes from offset 352, the file holds 47");
    CHECK_FAILS(sqffd_image_read_memory(b.data, 352, "d.nii", &im, err, sizeof err), &im, err, "d.nii",
                "the file holds 0");
    b.data[3] = 0x1c; /* big-endian sizeof_hdr 348 -> 540 (0x21c) */
    b.data[2] = 0x02;
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "2.nii", &im, err, sizeof err), &im, err, "2.nii",
                "a NIfTI-2 file (sizeof_hdr 540)");
    b.data[2] = 0x7f;
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "x.nii", &im, err, sizeof err), &im, err, "x.nii",
                "not a NIfTI-1 file: sizeof_hdr is");
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "x.dat", &im, err, sizeof err), &im, err, "x.dat",
                "not a NIfTI-1, MetaImage, NRRD or VTK file");
    CHECK_FAILS(sqffd_image_read_memory(b.data, 0, "e.nii", &im, err, sizeof err), &im, err, "e.nii", "file is empty");
    bytes_free(&b);
    CHECK_FAILS(sqffd_image_read_file("tests/data/no_such_file.nii", &im, err, sizeof err), &im, err,
                "tests/data/no_such_file.nii", "cannot open");
}

/* ---- MetaImage ------------------------------------------------------------ */

static const char *const met_names[7] = {"MET_UCHAR", "MET_CHAR", "MET_USHORT", "MET_SHORT",
                                         "MET_INT",   "MET_FLOAT", "MET_DOUBLE"};

/* By hand from the MetaIO convention: axis i runs along (0, 1, 0) with
   spacing 1.5, axis j along (-1, 0, 0) with 2, axis k along (0, 0, 1) with
   2.5; Offset (10, -20, 30). The NRRD test below states the same geometry. */
static const double permuted_affine[12] = {0, -2, 0, 10, 1.5, 0, 0, -20, 0, 0, 2.5, 30};

/* A detached header b and its data file raw written as NAME.EXT and
   NAME.raw, the pair read: the voxels of type, big-endian, on the permuted
   affine; from memory (as h.EXT) the header cannot reach its data file.
   0, with b and raw freed, when the files cannot be written (the test is
   skipped). */
static int check_detached(bytes *b, bytes *raw, const char *name, const char *ext, sqffd_voxel_type type)
{
    sqffd_image im;
    char err[256] = "", header[64], data[64], memory_name[16], part[128];
    snprintf(header, sizeof header, "%s.%s", name, ext);
    snprintf(data, sizeof data, "%s.raw", name);
    if (!write_file(header, b->data, b->size) || !write_file(data, raw->data, raw->size)) {
        printf("    (skipped: cannot write files in the working directory)\n");
        bytes_free(b);
        bytes_free(raw);
        return 0;
    }
    CHECK_MSG(sqffd_image_read_file(header, &im, err, sizeof err) == 0, "%s", err);
    CHECK(count_wrong_voxels(&im, type) == 0 && im.big_endian == 1);
    CHECK_AFFINE(&im, permuted_affine, 0);
    sqffd_image_free(&im);
    snprintf(memory_name, sizeof memory_name, "h.%s", ext);
    snprintf(part, sizeof part, "the voxels are in the data file '%s'", data);
    CHECK_FAILS(sqffd_image_read_memory(b->data, b->size, memory_name, &im, err, sizeof err), &im, err, memory_name,
                part);
    return 1;
}

/* A broken header read from memory as name fails with "name: ...part...";
   when it holds data_mark, 10 bytes of data follow it (too short for any
   case that gets that far). */
static void check_broken(const char *header, const char *data_mark, const char *name, const char *part)
{
    bytes b = {NULL, 0, 0};
    sqffd_image im;
    char err[256] = "";
    bytes_text(&b, "%s", header);
    if (strstr(header, data_mark)) bytes_put(&b, "0123456789", 10);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, name, &im, err, sizeof err), &im, err, name, part);
    bytes_free(&b);
}

static void mha_header(bytes *b, const char *type, int msb, const char *extra)
{
    bytes_text(b, "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = %s\n"
                  "TransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = 10 -20 30\nCenterOfRotation = 0 0 0\n"
                  "AnatomicalOrientation = RAI\nElementSpacing = 1.5 2 2.5\nDimSize = 4 3 2\nElementType = %s\n%s",
               msb ? "True" : "False", type, extra);
}

static void test_volume_io_metaimage(void)
{
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0};
    int t, order;
    for (t = 0; t < 7; t++)
        for (order = 0; order < 2; order++) {
            mha_header(&b, met_names[t], order, "ElementDataFile = LOCAL\r\n"); /* CRLF on the last line */
            put_voxels(&b, all_types[t], 4, 3, 2, 1, order);
            CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "m.mha", &im, err, sizeof err) == 0, "%s", err);
            if (im.buffer) {
                CHECK(strcmp(im.format, "MetaImage") == 0 && strcmp(im.stored_type, met_names[t]) == 0);
                CHECK(im.volume.type == all_types[t] && im.big_endian == order);
                CHECK_DIMS(&im, 4, 3, 2, 1);
                CHECK_MSG(count_wrong_voxels(&im, all_types[t]) == 0, "%s %d", met_names[t], order);
                CHECK(strcmp(im.affine_source, "TransformMatrix") == 0);
                CHECK_AFFINE(&im, permuted_affine, 0);
                CHECK(im.spacing[0] == 1.5 && im.spacing[1] == 2 && im.spacing[2] == 2.5);
                CHECK(im.volume.scale == 0 && im.volume.offset == 0);
                sqffd_image_free(&im);
            }
            bytes_free(&b);
        }

    /* 4-D, synonyms (ElementSize, Position, ElementByteOrderMSB), no matrix */
    {
        static const double diagonal[12] = {0.5, 0, 0, 1, 0, 0.25, 0, 2, 0, 0, 4, 3};
        bytes_text(&b, "NDims = 4\nDimSize = 4 3 2 2\nElementType = MET_SHORT\nElementByteOrderMSB = True\n"
                       "ElementSize = 0.5 0.25 4 0.8\nPosition = 1 2 3 0\nElementNumberOfChannels = 1\n"
                       "ElementDataFile = LOCAL\n");
        put_voxels(&b, SQFFD_VOXEL_I16, 4, 3, 2, 2, 1);
        CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "4d.mha", &im, err, sizeof err) == 0, "%s", err);
        CHECK_DIMS(&im, 4, 3, 2, 2);
        CHECK(im.frame_stride == 48 && im.time_step == 0.8);
        CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
        CHECK(strcmp(im.affine_source, "ElementSpacing") == 0);
        CHECK_AFFINE(&im, diagonal, 0);
        sqffd_image_free(&im);
        bytes_free(&b);
    }

    /* HeaderSize -1: the data are the last bytes; HeaderSize 5: 5 bytes skipped */
    mha_header(&b, "MET_SHORT", 0, "HeaderSize = -1\nElementDataFile = LOCAL\n");
    bytes_text(&b, "junk before the data");
    put_voxels(&b, SQFFD_VOXEL_I16, 4, 3, 2, 1, 0);
    CHECK_READS(&b, "e.mha", SQFFD_VOXEL_I16);
    mha_header(&b, "MET_SHORT", 0, "HeaderSize = 5\nElementDataFile = LOCAL\n");
    bytes_text(&b, "junk!");
    put_voxels(&b, SQFFD_VOXEL_I16, 4, 3, 2, 1, 0);
    CHECK_READS(&b, "s.mha", SQFFD_VOXEL_I16);
}

/* Python 3 zlib 1.2.13, level 9: zlib.compress of the 48 bytes of the
   4 x 3 x 2 int16 little-endian image voxel_value() gives (i + 10j + 100k - 50);
   _short of its first 46 bytes, _long of those 48 and 2 more. */
static const unsigned char zlib_i16_le[54] = {
    0x78, 0xda, 0x05, 0xc1, 0xb7, 0x01, 0x80, 0x20, 0x00, 0x00, 0xc1, 0x9f, 0xc9, 0xd0, 0x89, 0x74,
    0x86, 0xe5, 0x01, 0x3b, 0xd4, 0x4e, 0x65, 0x8e, 0xf7, 0x2e, 0x99, 0x2d, 0x1e, 0x56, 0x4f, 0x2f,
    0x6f, 0x1f, 0x5f, 0x3f, 0x9b, 0x1d, 0x3d, 0x03, 0x23, 0x13, 0x81, 0x99, 0xc8, 0xc2, 0xca, 0xc6,
    0xce, 0x0f, 0x48, 0x25, 0x19, 0x09,
};
static const unsigned char zlib_i16_le_short[52] = {
    0x78, 0xda, 0x05, 0xc1, 0x4b, 0x02, 0x40, 0x20, 0x00, 0x00, 0xd1, 0x39, 0x93, 0xb4, 0x0b, 0x3b,
    0x3a, 0xbd, 0xcf, 0x8e, 0xec, 0x92, 0x73, 0x4c, 0xef, 0xed, 0x1e, 0x9e, 0x5e, 0xde, 0x3e, 0x16,
    0x5f, 0xab, 0x9f, 0xcd, 0xdf, 0x81, 0xc0, 0x48, 0x24, 0x31, 0x31, 0xb3, 0xb0, 0xb2, 0x91, 0xe9,
    0x16, 0x13, 0x18, 0xc0,
};
static const unsigned char zlib_i16_le_long[55] = {
    0x78, 0xda, 0x05, 0xc1, 0x39, 0x02, 0x40, 0x30, 0x00, 0x00, 0xc1, 0xed, 0xfc, 0xc7, 0xd1, 0x85,
    0x74, 0xc4, 0xe7, 0x83, 0x8e, 0xe8, 0x90, 0x77, 0xac, 0x99, 0xec, 0xe6, 0xee, 0xe1, 0xe9, 0x65,
    0xf1, 0xf6, 0xf1, 0xf5, 0xb3, 0xda, 0xd2, 0xd1, 0x33, 0x10, 0x18, 0x99, 0x88, 0xcc, 0x2c, 0x24,
    0x56, 0x1a, 0x7e, 0x7a, 0x45, 0x19, 0x10,
};
/* The same three as gzip files (gzip.compress(..., 9, mtime=0)), and the
   4 x 3 x 2 x 2 int16 big-endian image (t = 0, 1) for the 4-D NRRD. */
static const unsigned char gzip_i16_le[66] = {
    0x1f, 0x8b, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x03, 0x05, 0xc1, 0xb7, 0x01, 0x80, 0x20,
    0x00, 0x00, 0xc1, 0x9f, 0xc9, 0xd0, 0x89, 0x74, 0x86, 0xe5, 0x01, 0x3b, 0xd4, 0x4e, 0x65, 0x8e,
    0xf7, 0x2e, 0x99, 0x2d, 0x1e, 0x56, 0x4f, 0x2f, 0x6f, 0x1f, 0x5f, 0x3f, 0x9b, 0x1d, 0x3d, 0x03,
    0x23, 0x13, 0x81, 0x99, 0xc8, 0xc2, 0xca, 0xc6, 0xce, 0x0f, 0x47, 0x84, 0xe8, 0x44, 0x30, 0x00,
    0x00, 0x00,
};
static const unsigned char gzip_i16_le_short[64] = {
    0x1f, 0x8b, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x03, 0x05, 0xc1, 0x4b, 0x02, 0x40, 0x20,
    0x00, 0x00, 0xd1, 0x39, 0x93, 0xb4, 0x0b, 0x3b, 0x3a, 0xbd, 0xcf, 0x8e, 0xec, 0x92, 0x73, 0x4c,
    0xef, 0xed, 0x1e, 0x9e, 0x5e, 0xde, 0x3e, 0x16, 0x5f, 0xab, 0x9f, 0xcd, 0xdf, 0x81, 0xc0, 0x48,
    0x24, 0x31, 0x31, 0xb3, 0xb0, 0xb2, 0x91, 0xe9, 0xe7, 0x28, 0x25, 0xaf, 0x2e, 0x00, 0x00, 0x00,
};
static const unsigned char gzip_i16_le_long[67] = {
    0x1f, 0x8b, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x03, 0x05, 0xc1, 0x39, 0x02, 0x40, 0x30,
    0x00, 0x00, 0xc1, 0xed, 0xfc, 0xc7, 0xd1, 0x85, 0x74, 0xc4, 0xe7, 0x83, 0x8e, 0xe8, 0x90, 0x77,
    0xac, 0x99, 0xec, 0xe6, 0xee, 0xe1, 0xe9, 0x65, 0xf1, 0xf6, 0xf1, 0xf5, 0xb3, 0xda, 0xd2, 0xd1,
    0x33, 0x10, 0x18, 0x99, 0x88, 0xcc, 0x2c, 0x24, 0x56, 0x1a, 0x7e, 0x2b, 0x5e, 0x75, 0x5b, 0x32,
    0x00, 0x00, 0x00,
};
static const unsigned char gzip_i16_be_4d[111] = {
    0x1f, 0x8b, 0x08, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0x03, 0x05, 0xc1, 0x39, 0x12, 0x82, 0x00,
    0x00, 0x03, 0xc0, 0xcc, 0x24, 0xaf, 0x40, 0xec, 0x00, 0x3b, 0x51, 0xd0, 0x4e, 0xb4, 0x53, 0xf9,
    0xb0, 0x47, 0x07, 0xd2, 0xe1, 0xdd, 0x29, 0x76, 0x1e, 0xef, 0x88, 0xbb, 0xbe, 0xf8, 0xea, 0x9b,
    0xef, 0x7e, 0xf8, 0xe9, 0xce, 0x2f, 0xbf, 0xfd, 0xf1, 0xd7, 0x3f, 0x64, 0xc8, 0x31, 0xc1, 0x14,
    0x33, 0x14, 0x98, 0x63, 0x81, 0x25, 0x56, 0x58, 0xa3, 0xe4, 0x86, 0x5b, 0xee, 0xb8, 0x67, 0xc5,
    0x9a, 0x07, 0x36, 0x6c, 0x79, 0xe4, 0x89, 0x67, 0x05, 0xea, 0x29, 0x54, 0x5f, 0x91, 0x62, 0x25,
    0x1a, 0x68, 0xa8, 0x54, 0x23, 0x8d, 0xff, 0x1f, 0xa2, 0x1e, 0x6b, 0x60, 0x00, 0x00, 0x00,
};

static void test_volume_io_metaimage_compressed(void)
{
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0};
    mha_header(&b, "MET_SHORT", 0, "CompressedData = True\nCompressedDataSize = 54\nElementDataFile = LOCAL\n");
    bytes_put(&b, zlib_i16_le, sizeof zlib_i16_le);
    bytes_text(&b, "trailing bytes after the stream, ignored: CompressedDataSize says where it ends");
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "z.mha", &im, err, sizeof err) == 0, "%s", err);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
    CHECK_AFFINE(&im, permuted_affine, 0);
    sqffd_image_free(&im);
    bytes_free(&b);
    /* without CompressedDataSize: the stream runs to the end */
    mha_header(&b, "MET_SHORT", 0, "CompressedData = True\nElementDataFile = LOCAL\n");
    bytes_put(&b, zlib_i16_le, sizeof zlib_i16_le);
    CHECK_READS(&b, "z.mha", SQFFD_VOXEL_I16);
    /* a stream shorter and one longer than DimSize promises */
    mha_header(&b, "MET_SHORT", 0, "CompressedData = True\nElementDataFile = LOCAL\n");
    bytes_put(&b, zlib_i16_le_short, sizeof zlib_i16_le_short);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "s.mha", &im, err, sizeof err), &im, err, "s.mha",
                "data: the zlib stream holds 46 bytes, the header promises 48");
    bytes_free(&b);
    mha_header(&b, "MET_SHORT", 0, "CompressedData = True\nElementDataFile = LOCAL\n");
    bytes_put(&b, zlib_i16_le_long, sizeof zlib_i16_le_long);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "l.mha", &im, err, sizeof err), &im, err, "l.mha",
                "data (48 bytes promised): zlib: ");
    bytes_free(&b);
    /* CompressedDataSize beyond the file */
    mha_header(&b, "MET_SHORT", 0, "CompressedData = True\nCompressedDataSize = 55\nElementDataFile = LOCAL\n");
    bytes_put(&b, zlib_i16_le, sizeof zlib_i16_le);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "c.mha", &im, err, sizeof err), &im, err, "c.mha",
                "data: the header promises 55 compressed bytes, the file holds 54");
    bytes_free(&b);
    /* a header promising far more than the stream can hold is refused before inflating */
    bytes_text(&b, "NDims = 3\nDimSize = 400 400 400\nElementType = MET_DOUBLE\nCompressedData = True\n"
                   "ElementDataFile = LOCAL\n"); /* (512 MB: under the 32-bit builds' 1 GiB limit too) */
    bytes_put(&b, zlib_i16_le, sizeof zlib_i16_le);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "bomb.mha", &im, err, sizeof err), &im, err, "bomb.mha",
                "data: the header promises 512000000 bytes, more than 54 compressed bytes can hold");
    bytes_free(&b);
}

/* .mhd + data file beside it (relative to the header), HeaderSize bytes skipped. */
static void test_volume_io_metaimage_detached(void)
{
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0}, raw = {NULL, 0, 0};
    mha_header(&b, "MET_USHORT", 1, "HeaderSize = 16\nElementDataFile = sqffd_test_mhd.raw\n");
    bytes_text(&raw, "sixteen bytes...");
    put_voxels(&raw, SQFFD_VOXEL_U16, 4, 3, 2, 1, 1);
    if (!check_detached(&b, &raw, "sqffd_test_mhd", "mhd", SQFFD_VOXEL_U16)) return;
    /* the data file one byte short */
    CHECK(write_file("sqffd_test_mhd.raw", raw.data, raw.size - 1));
    CHECK_FAILS(sqffd_image_read_file("sqffd_test_mhd.mhd", &im, err, sizeof err), &im, err, "sqffd_test_mhd.raw",
                "data: the header promises 48 bytes from offset 16, the file holds 47");
    remove("sqffd_test_mhd.raw");
    CHECK_FAILS(sqffd_image_read_file("sqffd_test_mhd.mhd", &im, err, sizeof err), &im, err, "sqffd_test_mhd.raw",
                "cannot open");
    remove("sqffd_test_mhd.mhd");
    bytes_free(&b);
    bytes_free(&raw);
}

static void test_volume_io_metaimage_broken(void)
{
    static const struct { const char *header; const char *part; } cases[] = {
        {"NDims = 3\nElementType = MET_SHORT\nElementDataFile = LOCAL\n", "no DimSize"},
        {"NDims = 3\nDimSize = 4 -3 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n",
         "DimSize: '-3' is not a size (a whole number, at least 1)"},
        {"NDims = 3\nDimSize = 4 3\nElementType = MET_SHORT\nElementDataFile = LOCAL\n", "DimSize: expected 3 sizes, found 2"},
        {"NDims = 2\nDimSize = 4 3\nElementType = MET_SHORT\nElementDataFile = LOCAL\n",
         "NDims = 2: only 3-D and 4-D images are supported"},
        {"NDims = 3\nDimSize = 4 3 2\nElementDataFile = LOCAL\n", "no ElementType"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_UINT\nElementDataFile = LOCAL\n",
         "ElementType 'MET_UINT' is not supported"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementNumberOfChannels = 3\nElementDataFile = LOCAL\n",
         "ElementNumberOfChannels = 3: only single-channel images are supported"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementDataFile = LIST\n",
         "ElementDataFile = LIST (one file per slice) is not supported"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementDataFile = s%03d.raw 1 2 1\n",
         "a file-name pattern (one file per slice) is not supported"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\n", "no ElementDataFile line"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nBinaryDataByteOrderMSB = maybe\nElementDataFile = LOCAL\n",
         "BinaryDataByteOrderMSB = 'maybe': expected True or False"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementSpacing = 1 nan 1\nElementDataFile = LOCAL\n",
         "ElementSpacing: 'nan' is not a finite number"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nTransformMatrix = 1 0 0 1\nElementDataFile = LOCAL\n",
         "TransformMatrix: expected 9 numbers, found 4"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nHeaderSize = -2\nElementDataFile = LOCAL\n",
         "HeaderSize = '-2': expected a whole number, at least -1"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nHeaderSize = 100\nElementDataFile = LOCAL\n",
         "data: they start at byte"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nHeaderSize = -1\nCompressedData = True\n"
         "ElementDataFile = LOCAL\n", "HeaderSize = -1 with compressed data needs CompressedDataSize"},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nBinaryData = False\nElementDataFile = LOCAL\n",
         "BinaryData = False (voxels as text) is not supported"},
        {"ObjectType = Mesh\nNDims = 3\nElementDataFile = LOCAL\n", "ObjectType = 'Mesh': not an image"},
        {"NDims = 3\nthis line has no equals sign\nElementDataFile = LOCAL\n", "line 2: expected \"Key = Value\""},
        {"NDims = 3\nDimSize = 4 3 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n",
         "data: the header promises 48 bytes from offset"},
    };
    size_t c;
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++)
        check_broken(cases[c].header, "ElementDataFile", "b.mha", cases[c].part);
}

/* ---- NRRD ----------------------------------------------------------------- */

static const char *const nrrd_type_names[7][2] = {{"uchar", "uint8"},   {"signed char", "int8"}, {"ushort", "uint16"},
                                                  {"short", "int16"},   {"int", "int32"},        {"float", "float"},
                                                  {"double", "double"}};

/* The permuted geometry of the MetaImage test, as a NRRD states it. */
static void nrrd_header(bytes *b, const char *type, const char *endian, const char *encoding, const char *extra)
{
    bytes_text(b, "NRRD0004\n# Complete NRRD file format specification at:\n# http://teem.sourceforge.net/nrrd/format.html\n"
                  "type: %s\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\n"
                  "space directions: (0,1.5,0) (-2, 0, 0) ( 0,0,2.5 )\nkinds: domain domain domain\n"
                  "endian: %s\nencoding: %s\nspace origin: (10,-20,30)\nsome key:=some value\n%s",
               type, endian, encoding, extra);
}

static void test_volume_io_nrrd(void)
{
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0};
    int t, order;
    for (t = 0; t < 7; t++)
        for (order = 0; order < 2; order++) {
            nrrd_header(&b, nrrd_type_names[t][0], order ? "big" : "little", "raw", "\n");
            put_voxels(&b, all_types[t], 4, 3, 2, 1, order);
            CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "n.nrrd", &im, err, sizeof err) == 0, "%s", err);
            if (im.buffer) {
                CHECK(strcmp(im.format, "NRRD") == 0 && strcmp(im.stored_type, nrrd_type_names[t][1]) == 0);
                CHECK(im.volume.type == all_types[t] && im.big_endian == order);
                CHECK_DIMS(&im, 4, 3, 2, 1);
                CHECK_MSG(count_wrong_voxels(&im, all_types[t]) == 0, "%s %d", nrrd_type_names[t][0], order);
                CHECK(strcmp(im.affine_source, "space directions") == 0);
                CHECK_AFFINE(&im, permuted_affine, 0);
                CHECK(im.spacing[0] == 1.5 && im.spacing[1] == 2 && im.spacing[2] == 2.5);
                sqffd_image_free(&im);
            }
            bytes_free(&b);
        }
    /* other spellings of the same types */
    {
        static const char *const spellings[] = {"unsigned char", "uint8_t", "int8", "short int", "signed short int",
                                                "int16_t", "unsigned short int", "uint16", "signed int", "int32_t"};
        static const int types[] = {0, 0, 1, 3, 3, 3, 2, 2, 4, 4};
        size_t s;
        for (s = 0; s < sizeof types / sizeof types[0]; s++) {
            nrrd_header(&b, spellings[s], "big", "raw", "\n");
            put_voxels(&b, all_types[types[s]], 4, 3, 2, 1, 1);
            CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "n.nrrd", &im, err, sizeof err) == 0, "%s", err);
            CHECK_MSG(im.volume.type == all_types[types[s]] && count_wrong_voxels(&im, all_types[types[s]]) == 0, "%s",
                      spellings[s]);
            sqffd_image_free(&im);
            bytes_free(&b);
        }
    }
    /* ascii voxels (endian may be absent) */
    nrrd_header(&b, "short", "little", "ascii", "\n");
    bytes_text(&b, "-50 -49 -48 -47\n-40 -39 -38 -37 -30 -29 -28 -27\n50 51 52 53 60 61 62 63 70 71 72 73\n");
    CHECK_READS(&b, "a.nrrd", SQFFD_VOXEL_I16);
    /* 4-D without space directions: spacings, the 4th axis is time */
    {
        static const double diagonal[12] = {1.5, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2.5, 0};
        bytes_text(&b, "NRRD0005\ntype: int16\ndimension: 4\nsizes: 4 3 2 2\nspacings: 1.5 2 2.5 0.8\n"
                       "endian: little\nencoding: raw\n\n");
        put_voxels(&b, SQFFD_VOXEL_I16, 4, 3, 2, 2, 0);
        CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "4.nrrd", &im, err, sizeof err) == 0, "%s", err);
        CHECK_DIMS(&im, 4, 3, 2, 2);
        CHECK(im.frame_stride == 48 && im.time_step == 0.8 && strcmp(im.affine_source, "spacings") == 0);
        CHECK_AFFINE(&im, diagonal, 0);
        CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
        sqffd_image_free(&im);
        bytes_free(&b);
    }
}

static void test_volume_io_nrrd_gzip_and_4d(void)
{
    static const double identity_shifted[12] = {1, 0, 0, -5, 0, 1, 0, 6, 0, 0, 1, 7};
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0};
    size_t i, j, k, t;
    nrrd_header(&b, "short", "little", "gzip", "\n");
    bytes_put(&b, gzip_i16_le, sizeof gzip_i16_le);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "g.nrrd", &im, err, sizeof err) == 0, "%s", err);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
    CHECK_AFFINE(&im, permuted_affine, 0);
    sqffd_image_free(&im);
    bytes_free(&b);

    nrrd_header(&b, "short", "little", "gz", "\n");
    bytes_put(&b, gzip_i16_le_short, sizeof gzip_i16_le_short);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "s.nrrd", &im, err, sizeof err), &im, err, "s.nrrd",
                "data: the gzip stream holds 46 bytes, the header promises 48");
    bytes_free(&b);
    nrrd_header(&b, "short", "little", "gzip", "\n");
    bytes_put(&b, gzip_i16_le_long, sizeof gzip_i16_le_long);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "l.nrrd", &im, err, sizeof err), &im, err, "l.nrrd",
                "data (48 bytes promised): gzip: ");
    bytes_free(&b);
    /* byte skip on gzip data counts decompressed bytes: skipping 2 leaves 46 */
    nrrd_header(&b, "short", "little", "gzip", "byte skip: 2\n\n");
    bytes_put(&b, gzip_i16_le, sizeof gzip_i16_le);
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "k.nrrd", &im, err, sizeof err), &im, err, "k.nrrd",
                "the gzip stream holds 48 bytes, the header promises 50");
    bytes_free(&b);

    /* 4-D, gzip, big-endian, the time axis "none" last */
    bytes_text(&b, "NRRD0004\ntype: short\ndimension: 4\nspace: RAS\nsizes: 4 3 2 2\n"
                   "space directions: (1,0,0) (0,1,0) (0,0,1) none\nspace origin: (-5,6,7)\n"
                   "kinds: domain domain domain list\nendian: big\nencoding: gzip\n\n");
    bytes_put(&b, gzip_i16_be_4d, sizeof gzip_i16_be_4d);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "4d.nrrd", &im, err, sizeof err) == 0, "%s", err);
    CHECK_DIMS(&im, 4, 3, 2, 2);
    CHECK(im.frame_stride == 48 && im.time_step == 0);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
    CHECK_AFFINE(&im, identity_shifted, 0);
    sqffd_image_free(&im);
    bytes_free(&b);

    /* the non-spatial axis first (e.g. a list of 2 values per voxel): frames
       interleave, so the views stride over them; raw, little-endian */
    bytes_text(&b, "NRRD0004\ntype: short\ndimension: 4\nsizes: 2 4 3 2\n"
                   "space directions: none (1,0,0) (0,1,0) (0,0,1)\nspace origin: (-5,6,7)\nendian: little\n"
                   "encoding: raw\n\n");
    for (k = 0; k < 2; k++)
        for (j = 0; j < 3; j++)
            for (i = 0; i < 4; i++)
                for (t = 0; t < 2; t++) put_voxel(&b, SQFFD_VOXEL_I16, voxel_value(SQFFD_VOXEL_I16, i, j, k, t), 0);
    CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "n.nrrd", &im, err, sizeof err) == 0, "%s", err);
    CHECK_DIMS(&im, 4, 3, 2, 2);
    CHECK(im.frame_stride == 2 && im.volume.strides[0] == 4 && im.volume.strides[1] == 16 &&
          im.volume.strides[2] == 48);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I16) == 0);
    CHECK_AFFINE(&im, identity_shifted, 0);
    sqffd_image_free(&im);
    bytes_free(&b);
}

/* .nhdr + raw data file: line skip, then byte skip; and byte skip -1. */
static void test_volume_io_nrrd_detached(void)
{
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0}, raw = {NULL, 0, 0};
    nrrd_header(&b, "int32", "big", "raw", "data file: sqffd_test_nhdr.raw\nline skip: 2\nbyte skip: 3\n");
    bytes_text(&raw, "first line\nsecond line\nxyz");
    put_voxels(&raw, SQFFD_VOXEL_I32, 4, 3, 2, 1, 1);
    if (!check_detached(&b, &raw, "sqffd_test_nhdr", "nhdr", SQFFD_VOXEL_I32)) return;
    bytes_free(&b);
    /* byte skip -1: the data are the file's last bytes */
    nrrd_header(&b, "int32", "big", "raw", "data file: ./sqffd_test_nhdr.raw\nbyte skip: -1\n");
    CHECK(write_file("sqffd_test_nhdr.nhdr", b.data, b.size));
    CHECK_MSG(sqffd_image_read_file("sqffd_test_nhdr.nhdr", &im, err, sizeof err) == 0, "%s", err);
    CHECK(count_wrong_voxels(&im, SQFFD_VOXEL_I32) == 0);
    sqffd_image_free(&im);
    bytes_free(&b);
    /* more lines to skip than the data file has */
    nrrd_header(&b, "int32", "big", "raw", "data file: sqffd_test_nhdr.raw\nline skip: 5\n");
    CHECK(write_file("sqffd_test_nhdr.nhdr", b.data, b.size));
    CHECK_FAILS(sqffd_image_read_file("sqffd_test_nhdr.nhdr", &im, err, sizeof err), &im, err, "sqffd_test_nhdr.raw",
                "line skip 5: the data hold only");
    remove("sqffd_test_nhdr.nhdr");
    remove("sqffd_test_nhdr.raw");
    bytes_free(&b);
    bytes_free(&raw);
}

static void test_volume_io_nrrd_broken(void)
{
    static const struct { const char *header; const char *part; } cases[] = {
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: bzip2\n\n",
         "encoding 'bzip2' is not supported (raw, gzip and ascii are)"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: hex\n\n", "encoding 'hex'"},
        {"NRRD0009\ntype: short\n\n", "magic 'NRRD0009': only NRRD0001 to NRRD0005 are known"},
        {"NRRD0004\ntype: unsigned int\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n\n",
         "type 'unsigned int' is not supported"},
        {"NRRD0004\ntype: int64\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n\n", "type 'int64'"},
        {"NRRD0004\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n\n", "no type field"},
        {"NRRD0004\ntype: short\ndimension: 2\nsizes: 4 3\nendian: little\nencoding: raw\n\n",
         "dimension '2': only 3-D and 4-D images are supported"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 -3 2\nendian: little\nencoding: raw\n\n",
         "sizes: '-3' is not a size"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 0 2\nendian: little\nencoding: raw\n\n",
         "sizes: '0' is not a size"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2 5\nendian: little\nencoding: raw\n\n",
         "sizes: more than 3 sizes"},
        {"NRRD0004\ntype: double\ndimension: 4\nsizes: 100000 100000 100000 100000\nendian: little\nencoding: raw\n\n",
         "voxels of 8 bytes: more than"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nencoding: raw\n\n",
         "no endian field (needed for 2-byte voxels)"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: middle\nencoding: raw\n\n",
         "endian 'middle': expected little or big"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
         "space directions: (1,0,0) none (0,0,1)\n\n",
         "space directions: 2 vectors; exactly 3 axes must be spatial"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
         "space directions: (1,0,0) (0,1) (0,0,1)\n\n", "space directions: expected 3 numbers, found 2"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
         "space directions: (1,0,0) (0,1,0) (0,0,1\n\n", "space directions: a vector without its ')'"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
         "space directions: (1,0,0) (0,1,0) (0,0,1) (1,1,1)\n\n", "space directions: more than 3 entries"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n"
         "space origin: (1,inf,0)\n\n", "space origin: 'inf' is not a finite number"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\nspace: RAST\n\n",
         "space 'RAST': only 3-D spaces are supported"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\nspacings: 1 nan 1\n\n",
         "spacings: axis 1 is spatial but its spacing is nan"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: gzip\nbyte skip: -1\n\n",
         "byte skip -1 (data at the end) needs raw encoding"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\ndata file: LIST\n",
         "data file: LIST (several data files) is not supported"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\ndata file: s%03d.raw 1 4 1\n",
         "a file-name pattern (several data files) is not supported"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n",
         "no blank line after the header"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: raw\n\n",
         "data: the header promises 48 bytes from offset"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nendian: little\nencoding: gzip\n\n",
         "data (48 bytes promised): gzip: "},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 1 1 1\nencoding: ascii\n\n",
         "data: value 0, '0123456789', is not a whole number in the type's range"},
        {"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 3 2\nencoding: ascii\n\n",
         "data: the header promises 24 values, 10 bytes of text cannot hold them"},
        {"NRRD0004\nthis line has no colon\n\n", "line 2: expected \"field: value\""},
    };
    size_t c;
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++) check_broken(cases[c].header, "\n\n", "b.nrrd", cases[c].part);
    {   /* ascii: out of the type's range, and too few values */
        bytes b = {NULL, 0, 0};
        sqffd_image im;
        char err[256] = "";
        bytes_text(&b, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\n1 256\n");
        CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "r.nrrd", &im, err, sizeof err), &im, err, "r.nrrd",
                    "data: value 1, '256', is not a whole number in the type's range");
        bytes_free(&b);
        bytes_text(&b, "NRRD0004\ntype: float\ndimension: 3\nsizes: 2 1 1\nencoding: ascii\n\n1.5  \n");
        CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "f.nrrd", &im, err, sizeof err), &im, err, "f.nrrd",
                    "data: 1 of 2 values present");
        bytes_free(&b);
    }
}

/* ---- legacy VTK STRUCTURED_POINTS ----------------------------------------- */

static const char *const vtk_type_names[7] = {"unsigned_char", "char", "unsigned_short", "short", "int", "float",
                                              "double"};

/* A STRUCTURED_POINTS header of 4 x 3 x 2 voxels; `before` goes between the geometry and POINT_DATA. */
static void vtk_volume_header(bytes *b, int binary, const char *type, const bytes *before)
{
    bytes_text(b, "# vtk DataFile Version 3.0\nvolume\n%s\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 3 2\n"
                  "SPACING 1.5 2 2.5\nORIGIN 10 -20 30\n", binary ? "BINARY" : "ASCII");
    bytes_put(b, before->data, before->size);
    bytes_text(b, "POINT_DATA 24\nSCALARS voxels %s 1\nLOOKUP_TABLE default\n", type);
}

/* The voxels of an nx x ny x nz image as VTK holds them: big endian, or ASCII numbers. */
static void put_vtk_voxels(bytes *b, int binary, sqffd_voxel_type type, size_t nx, size_t ny, size_t nz)
{
    size_t i, j, k;
    if (binary) put_voxels(b, type, nx, ny, nz, 1, 1);
    else
        for (k = 0; k < nz; k++)
            for (j = 0; j < ny; j++)
                for (i = 0; i < nx; i++) bytes_text(b, "%.17g%c", voxel_value(type, i, j, k, 0), i + 1 < nx ? ' ' : '\n');
    bytes_put(b, "\n", 1);
}

/* Every voxel type, ASCII and binary (big endian), with sections to skip
   before the voxels (CELL_DATA scalars, FIELD data, other point attributes)
   or not; unsigned_int, widened to float64. */
static void test_volume_io_vtk(void)
{
    static const double affine[12] = {1.5, 0, 0, 10, 0, 2, 0, -20, 0, 0, 2.5, 30};
    sqffd_image im;
    char err[256] = "";
    bytes b = {NULL, 0, 0};
    int t, binary, skip;
    for (t = 0; t < 7; t++)
        for (binary = 0; binary < 2; binary++)
            for (skip = 0; skip < 2; skip++) {
                bytes before = {NULL, 0, 0};
                if (skip) { /* 6 cells of floats, FIELD data, a VECTORS of the points */
                    bytes_text(&before, "CELL_DATA 6\nSCALARS cells float\nLOOKUP_TABLE default\n");
                    put_vtk_voxels(&before, binary, SQFFD_VOXEL_F32, 3, 2, 1);
                    bytes_text(&before, "FIELD FieldData 1\nTIME 1 1 double\n");
                    put_vtk_voxels(&before, binary, SQFFD_VOXEL_F64, 1, 1, 1);
                    bytes_text(&before, "POINT_DATA 24\nVECTORS v float\n");
                    put_vtk_voxels(&before, binary, SQFFD_VOXEL_F32, 8, 9, 1);
                }
                vtk_volume_header(&b, binary, vtk_type_names[t], &before);
                put_vtk_voxels(&b, binary, all_types[t], 4, 3, 2);
                CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "v.vtk", &im, err, sizeof err) == 0, "%s", err);
                if (im.buffer) {
                    CHECK(strcmp(im.format, "VTK") == 0 && strcmp(im.stored_type, vtk_type_names[t]) == 0);
                    CHECK(im.volume.type == all_types[t] && im.big_endian == binary);
                    CHECK_DIMS(&im, 4, 3, 2, 1);
                    CHECK_MSG(count_wrong_voxels(&im, all_types[t]) == 0, "%s %s", vtk_type_names[t],
                              binary ? "binary" : "ascii");
                    CHECK(strcmp(im.affine_source, "SPACING and ORIGIN") == 0);
                    CHECK_AFFINE(&im, affine, 0);
                    CHECK(im.spacing[0] == 1.5 && im.spacing[1] == 2 && im.spacing[2] == 2.5);
                    sqffd_image_free(&im);
                }
                bytes_free(&b);
                bytes_free(&before);
            }
    /* unsigned_int: values past int32, read as float64 */
    for (binary = 0; binary < 2; binary++) {
        static const double big[2] = {4294967295.0, 2147483648.0};
        unsigned char raw[4];
        size_t i, k;
        bytes_text(&b, "# vtk DataFile Version 3.0\nu\n%s\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 1 1\n"
                       "POINT_DATA 2\nSCALARS u unsigned_int\nLOOKUP_TABLE default\n", binary ? "BINARY" : "ASCII");
        for (i = 0; i < 2; i++) {
            uint32_t u = (uint32_t)big[i];
            if (!binary) { bytes_text(&b, "%lu\n", (unsigned long)u); continue; }
            for (k = 0; k < 4; k++) raw[k] = (unsigned char)(u >> (24 - 8 * k));
            bytes_put(&b, raw, 4);
        }
        CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "u.vtk", &im, err, sizeof err) == 0, "%s", err);
        if (im.buffer) {
            double v[2];
            memcpy(v, im.buffer, sizeof v);
            CHECK(im.volume.type == SQFFD_VOXEL_F64 && strcmp(im.stored_type, "unsigned_int") == 0);
            CHECK(im.volume.strides[0] == 8 && im.volume.strides[1] == 16);
            CHECK(v[0] == big[0] && v[1] == big[1]);
            CHECK(strcmp(im.affine_source, "none") == 0);
            sqffd_image_free(&im);
        }
        bytes_free(&b);
    }
    bytes_text(&b, "# vtk DataFile Version 3.0\nu\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 1 1\n"
                   "POINT_DATA 2\nSCALARS u unsigned_int\nLOOKUP_TABLE default\n1 4294967296\n");
    CHECK_FAILS(sqffd_image_read_memory(b.data, b.size, "u.vtk", &im, err, sizeof err), &im, err, "u.vtk",
                "data: value 1, '4294967296', is not a whole number in the type's range");
    bytes_free(&b);
    /* DIRECTION (VTK 9) and ASPECT_RATIO (the old name of SPACING) */
    {
        static const double rotated[12] = {0, -2, 0, 1, 1.5, 0, 0, 2, 0, 0, 2.5, 3};
        bytes_text(&b, "# vtk DataFile Version 3.0\nd\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 3 2\n"
                       "ASPECT_RATIO 1.5 2 2.5\nDIRECTION 0 -1 0 1 0 0 0 0 1\nORIGIN 1 2 3\nPOINT_DATA 24\n"
                       "SCALARS s short 1\nLOOKUP_TABLE default\n");
        put_vtk_voxels(&b, 0, SQFFD_VOXEL_I16, 4, 3, 2);
        CHECK_MSG(sqffd_image_read_memory(b.data, b.size, "d.vtk", &im, err, sizeof err) == 0, "%s", err);
        CHECK_AFFINE(&im, rotated, 0);
        CHECK(strcmp(im.affine_source, "DIRECTION, SPACING, ORIGIN") == 0);
        sqffd_image_free(&im);
        bytes_free(&b);
    }
}

/* The iso-surface points of a frame (level 50), malloc'd; *n their count. */
static double *iso_points(const sqffd_volume *v, size_t *n)
{
    sqffd_iso_options o = sqffd_iso_options_default();
    size_t size, room = 0;
    void *work;
    double *out;
    o.level = 50;
    *n = 0;
    if (sqffd_iso_workspace_size(v, &o, &size) != SQFFD_OK) return NULL;
    work = test_malloc(size);
    if (sqffd_iso_points(v, &o, NULL, NULL, 0, &room, work, size) != SQFFD_OK || room == 0) { free(work); return NULL; }
    out = (double *)test_malloc(3 * room * sizeof *out);
    if (sqffd_iso_points(v, &o, out, NULL, room, n, work, size) != SQFFD_OK) { free(work); free(out); return NULL; }
    free(work);
    return out;
}

/* A ball as a binary and an ASCII STRUCTURED_POINTS file and as a NRRD of
   the same geometry: the same iso-surface points, bit for bit. */
static void test_volume_io_vtk_ball(void)
{
    static const char *const names[3] = {"ball.nrrd", "ball.vtk", "ball_ascii.vtk"};
    double *points[3] = {NULL, NULL, NULL};
    size_t n[3] = {0, 0, 0}, i, j, k, f;
    sqffd_image im;
    char err[256] = "";
    for (f = 0; f < 3; f++) {
        bytes b = {NULL, 0, 0};
        if (f == 0)
            bytes_text(&b, "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 20 22 24\nspacings: 0.5 0.75 1\n"
                           "space origin: (-4,2,7)\nencoding: raw\n\n");
        else
            bytes_text(&b, "# vtk DataFile Version 3.0\nball\n%s\nDATASET STRUCTURED_POINTS\nDIMENSIONS 20 22 24\n"
                           "SPACING 0.5 0.75 1\nORIGIN -4 2 7\nPOINT_DATA 10560\nSCALARS ball unsigned_char 1\n"
                           "LOOKUP_TABLE default\n", f == 1 ? "BINARY" : "ASCII");
        for (k = 0; k < 24; k++)
            for (j = 0; j < 22; j++)
                for (i = 0; i < 20; i++) {
                    double x = 0.5 * (double)i - 4.5, y = 0.75 * (double)j - 7.5, z = (double)k - 11.5;
                    unsigned value = x * x + y * y + z * z < 36 ? 100u + (unsigned)(i + j + k) : 0u;
                    if (f == 2) bytes_text(&b, "%u ", value);
                    else bytes_byte(&b, value);
                }
        CHECK_MSG(sqffd_image_read_memory(b.data, b.size, names[f], &im, err, sizeof err) == 0, "%s", err);
        if (im.buffer) {
            points[f] = iso_points(&im.volume, &n[f]);
            sqffd_image_free(&im);
        }
        bytes_free(&b);
    }
    CHECK_MSG(n[0] > 500 && points[0], "%lu iso points", (unsigned long)n[0]);
    for (f = 1; f < 3; f++)
        CHECK_MSG(n[f] == n[0] && points[f] && points[0] && memcmp(points[f], points[0], 3 * n[0] * sizeof(double)) == 0,
                  "%s: %lu points, the NRRD %lu", names[f], (unsigned long)n[f], (unsigned long)n[0]);
    for (f = 0; f < 3; f++) free(points[f]);
}

static void test_volume_io_vtk_broken(void)
{
#define VTK_HEAD "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET STRUCTURED_POINTS\n"
#define VTK_DATA "POINT_DATA 24\nSCALARS s short 1\nLOOKUP_TABLE default\n"
    static const struct { const char *header; const char *part; } cases[] = {
        {VTK_HEAD "DIMENSIONS 0 3 2\n" VTK_DATA, "DIMENSIONS (line 5): 0 is not a size from 1 to"},
        {VTK_HEAD "DIMENSIONS 4 99999999999999999 2\n" VTK_DATA, "99999999999999999 is not a size from 1 to"},
        {VTK_HEAD "DIMENSIONS 4 3 -2\n" VTK_DATA, "DIMENSIONS (line 5): '-2' is not a count"},
        {VTK_HEAD "DIMENSIONS 1048576 1048576 1048576\n" VTK_DATA, /* (each a size on 32-bit too; their product not) */
         "1048576 x 1048576 x 1048576 x 1 voxels of 2 bytes: more than"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nPOINT_DATA 23\nSCALARS s short 1\nLOOKUP_TABLE default\n",
         "POINT_DATA 23, but DIMENSIONS 4 x 3 x 2 make 24 points"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nPOINT_DATA 24\nSCALARS s short 3\nLOOKUP_TABLE default\n",
         "SCALARS (line 7): 3 components a voxel; one is read"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nPOINT_DATA 24\nSCALARS s vtktypeint64\nLOOKUP_TABLE default\n",
         "64-bit integer voxels are not read"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nPOINT_DATA 24\nSCALARS s bit\nLOOKUP_TABLE default\n",
         "value type 'bit' is not read"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nPOINT_DATA 24\nSCALARS s short\n", "file ends before LOOKUP_TABLE"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nSPACING 1 nan 1\n" VTK_DATA, "SPACING (line 6): 'nan' is not a finite number"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nSPACING 1 0 1\n" VTK_DATA, "SPACING (line 6): a spacing of 0"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nORIGIN 1 2\n" VTK_DATA, "ORIGIN (line 6): 'POINT_DATA' is not a finite number"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nDIRECTION 1e308 0 0 0 1 0 0 0 1\nSPACING 10 1 1\n" VTK_DATA,
         "DIRECTION x SPACING holds a value that is not finite"},
        {VTK_HEAD VTK_DATA, "SCALARS (line 6): no DIMENSIONS before the voxels"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nCELL_DATA 5\nSCALARS s short 1\nLOOKUP_TABLE default\n",
         "no SCALARS in POINT_DATA: no voxel values"},
        {VTK_HEAD "DIMENSIONS 4 3 2\nCOLOR 1\n" VTK_DATA, "line 6: unknown keyword 'COLOR' in DATASET STRUCTURED_POINTS"},
        {VTK_HEAD "DIMENSIONS 4 3 2\n" VTK_DATA, "data: the header promises 48 bytes from offset"},
        {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 4 3 2\n" VTK_DATA,
         "data: the header promises 24 values, 11 bytes of text cannot hold them"},
        {"# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 1 float\n",
         "DATASET POLYDATA holds points, not a volume (a volume is STRUCTURED_POINTS)"},
        {"# vtk DataFile Version 3.0\nt\nBINARI\nDATASET STRUCTURED_POINTS\n", "line 3: expected ASCII or BINARY"},
    };
    size_t c;
    for (c = 0; c < sizeof cases / sizeof cases[0]; c++)
        check_broken(cases[c].header, "LOOKUP_TABLE default\n", "b.vtk", cases[c].part);
    check_broken("# vtk DataFile Version 3.0\nt\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 1 1\nPOINT_DATA 2\n"
                 "SCALARS s float 1\nLOOKUP_TABLE default\n1 nan\n", "none", "n.vtk",
                 "data: value 1, 'nan', is not a finite number");
#undef VTK_HEAD
#undef VTK_DATA
}

/* ---- detection ------------------------------------------------------------ */

static void test_volume_io_detection(void)
{
    nifti_fields f = nifti_default(SQFFD_VOXEL_I16, 1);
    bytes b = {NULL, 0, 0};
    static const unsigned char gz[2] = {0x1f, 0x8b};
    nifti_header(&b, &f);
    CHECK(sqffd_image_is_volume_file("scan.dat", b.data, b.size) == 1);
    CHECK(sqffd_image_is_volume_file(NULL, b.data, 348) == 1);
    CHECK(sqffd_image_is_volume_file(NULL, b.data, 347) == 0); /* the magic is not there yet */
    memcpy(b.data + 344, "abc", 4);
    CHECK(sqffd_image_is_volume_file("scan.dat", b.data, b.size) == 0);
    CHECK(sqffd_image_is_volume_file("a.nrrd", "NRRD0004\n", 9) == 1);
    CHECK(sqffd_image_is_volume_file("a.txt", "NRRD0004\n", 9) == 1);
    CHECK(sqffd_image_is_volume_file("a.txt", "ObjectType = Image\nNDims = 3\n", 30) == 1);
    CHECK(sqffd_image_is_volume_file("a.txt", "  NDims=3\n", 10) == 1);
    CHECK(sqffd_image_is_volume_file("a.xyz", "1 2 3\n4 5 6\n", 12) == 0);
    CHECK(sqffd_image_is_volume_file("bunny.ply", "ply\nformat ascii 1.0\n", 21) == 0);
    CHECK(sqffd_image_is_volume_file("brain.nii.gz", gz, 2) == 1);
    CHECK(sqffd_image_is_volume_file("BRAIN.NII", NULL, 0) == 1);
    CHECK(sqffd_image_is_volume_file("points.xyz.gz", gz, 2) == 0);
    CHECK(sqffd_image_is_volume_file("a.mhd", "", 0) == 1 && sqffd_image_is_volume_file("a.nhdr", "", 0) == 1);
    /* VTK: STRUCTURED_POINTS is a volume; other datasets, and a .vtk name alone, are points */
    CHECK(sqffd_image_is_volume_file("a.dat", "# vtk DataFile Version 3.0\nCT\nBINARY\nDATASET STRUCTURED_POINTS\n", 63));
    CHECK(sqffd_image_is_volume_file("a.vtk", "# vtk DataFile Version 2.0\n\nascii\n\ndataset structured_points", 60));
    CHECK(!sqffd_image_is_volume_file("a.vtk", "# vtk DataFile Version 3.0\nsqffd\nBINARY\nDATASET POLYDATA\n", 57));
    CHECK(!sqffd_image_is_volume_file("a.vtk", "# vtk DataFile Version 3.0\nCT\nBINARY\nDATASET STRUCTURED_POI", 59));
    CHECK(!sqffd_image_is_volume_file("a.vtk", NULL, 0));
    bytes_free(&b);
}

void suite_volume_io(void)
{
    RUN_TEST(test_volume_io_nifti_anatomical);
    RUN_TEST(test_volume_io_nifti_kmeans_gz);
    RUN_TEST(test_volume_io_nifti_example4d);
    RUN_TEST(test_volume_io_nifti_types_and_qform);
    RUN_TEST(test_volume_io_nifti_affine_sources);
    RUN_TEST(test_volume_io_nifti_pair);
    RUN_TEST(test_volume_io_nifti_broken);
    RUN_TEST(test_volume_io_metaimage);
    RUN_TEST(test_volume_io_metaimage_compressed);
    RUN_TEST(test_volume_io_metaimage_detached);
    RUN_TEST(test_volume_io_metaimage_broken);
    RUN_TEST(test_volume_io_nrrd);
    RUN_TEST(test_volume_io_nrrd_gzip_and_4d);
    RUN_TEST(test_volume_io_nrrd_detached);
    RUN_TEST(test_volume_io_nrrd_broken);
    RUN_TEST(test_volume_io_vtk);
    RUN_TEST(test_volume_io_vtk_ball);
    RUN_TEST(test_volume_io_vtk_broken);
    RUN_TEST(test_volume_io_detection);
}
