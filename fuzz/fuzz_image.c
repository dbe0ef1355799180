/* libFuzzer target: the bytes go to sqffd_image_read_memory under each
   single-file name (.nii, .nii.gz, .mha, .nrrd, .vtk; the name only matters when
   the content does not tell the format). Checks the reader's contract beyond
   "no crash": success means dims and frames of at least 1, a finite affine,
   and every voxel of every frame readable through the views (all summed, so
   the sanitizers see each byte); failure means an empty image and a message
   "NAME: ...". */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include "../examples/sqffd_image.h"

/* The sum of every stored value of a view. */
static double sum_volume(const sqffd_volume *v)
{
    double sum = 0;
    size_t i, j, k;
    for (k = 0; k < v->dims[2]; k++)
        for (j = 0; j < v->dims[1]; j++)
            for (i = 0; i < v->dims[0]; i++) {
                const char *p = (const char *)v->data + (ptrdiff_t)i * v->strides[0] +
                                (ptrdiff_t)j * v->strides[1] + (ptrdiff_t)k * v->strides[2];
                switch (v->type) {
                case SQFFD_VOXEL_U8: sum += *(const unsigned char *)p; break;
                case SQFFD_VOXEL_I8: { int8_t x; memcpy(&x, p, 1); sum += x; break; }
                case SQFFD_VOXEL_U16: { uint16_t x; memcpy(&x, p, 2); sum += x; break; }
                case SQFFD_VOXEL_I16: { int16_t x; memcpy(&x, p, 2); sum += x; break; }
                case SQFFD_VOXEL_I32: { int32_t x; memcpy(&x, p, 4); sum += x; break; }
                case SQFFD_VOXEL_F32: { float x; memcpy(&x, p, 4); sum += (double)x; break; }
                case SQFFD_VOXEL_F64: { double x; memcpy(&x, p, 8); sum += x; break; }
                default: abort();
                }
            }
    return sum;
}

static void check_reader(const uint8_t *data, size_t size, const char *name)
{
    sqffd_image image;
    char err[256];
    size_t t, a;
    volatile double sum = 0;
    if (sqffd_image_read_memory(data, size, name, &image, err, sizeof err) == 0) {
        if (!image.buffer || image.volume.data != image.buffer || image.frames < 1) abort();
        for (a = 0; a < 3; a++)
            if (image.volume.dims[a] < 1 || image.volume.strides[a] == 0) abort();
        for (a = 0; a < 16; a++)
            if (!isfinite(image.volume.affine[a])) abort();
        if (image.volume.affine[12] != 0 || image.volume.affine[13] != 0 || image.volume.affine[14] != 0 ||
            image.volume.affine[15] != 1)
            abort();
        for (t = 0; t < image.frames; t++) {
            sqffd_volume frame = sqffd_image_frame(&image, t);
            if (!frame.data) abort();
            sum += sum_volume(&frame);
        }
        if (sqffd_image_frame(&image, image.frames).data != NULL) abort();
        (void)sum;
        sqffd_image_free(&image);
        if (image.buffer) abort();
    } else {
        if (image.buffer || image.volume.data || image.frames) abort();
        if (strncmp(err, name, strlen(name)) != 0 || strncmp(err + strlen(name), ": ", 2) != 0) abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check_reader(data, size, "fuzz.nii");
    check_reader(data, size, "fuzz.nii.gz");
    check_reader(data, size, "fuzz.mha");
    check_reader(data, size, "fuzz.nrrd");
    check_reader(data, size, "fuzz.vtk");
    return 0;
}
