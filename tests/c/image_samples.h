/* image_samples.h - test images of every format opaline reads, written through OpenImageIO
 * (image_samples.cpp), for the image tests and the image fuzz target's seeds. */
#ifndef OPALINE_IMAGE_SAMPLES_H
#define OPALINE_IMAGE_SAMPLES_H

#ifdef __cplusplus
extern "C" {
#endif

/* Writes pixels (w x h, channels interleaved, rows from the top) to path in the format its
 * extension names, each value stored as type ("uint8", "uint16", "half" or "float"; integer
 * types take [0, 1], stored as round(v x largest code)). names: the channels' names, or NULL
 * for OpenImageIO's defaults (R G B A; Y for grey). 0 on success, else -1 with the reason on
 * stderr. */
int op_test_write_image(const char *path, int w, int h, int channels, const char *type,
                        const float *pixels, const char *const *names);

#ifdef __cplusplus
}
#endif
#endif
