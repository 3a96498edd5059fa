/* fuzz_exr.c: image bytes (EXR G-buffers and their metadata, PNG previews, anything else
 * OpenImageIO recognises) through io_image_read_memory.
 *
 * Invariants checked on every input:
 *   - failure leaves the image empty (io.h: "on failure *out is empty") and says why;
 *   - success gives a size within the context's limits, unique non-empty channel names, exactly
 *     one plane per channel matching its type, and attributes whose payloads match their types;
 *     every pixel and attribute value is read (ASan checks the reads);
 *   - io_image_find_channel / io_image_find_attr find what the image lists. */
#include "fuzz.h"

#include "io/io.h"

#include <string.h>

int obs_fuzz_exr(const uint8_t *data, size_t size)
{
    obs_context *ctx = fuzz_context();
    io_image im;
    /* EXR and PNG are recognised by their magic numbers; the name picks the reader for the rest */
    obs_status st = io_image_read_memory(ctx, "fuzz.exr", data, size, &im);
    if (st != OBS_STATUS_OK) {
        fuzz_require(im.channel_count == 0 && im.names == NULL && im.f32 == NULL && im.u32 == NULL &&
                         im.attrs == NULL && im.attr_count == 0,
                     "a failed read leaves the image empty");
        fuzz_require(obs_context_last_error(ctx)[0] != '\0', "a failed read says why");
        obs_context_destroy(ctx);
        return 0;
    }
    const obs_limits *lim = obs_context_limits(ctx);
    fuzz_require(im.width >= 1 && im.height >= 1 && im.channel_count >= 1, "a read image is not empty");
    fuzz_require((int64_t)im.width * im.height * im.channel_count <= lim->max_image_pixels,
                 "a read image is within max_image_pixels");
    uint32_t h = 0;
    for (int c = 0; c < im.channel_count; c++) {
        fuzz_require(im.names[c][0] != '\0' && memchr(im.names[c], '\0', sizeof im.names[c]) != NULL,
                     "channel names are non-empty and terminated");
        fuzz_require(io_image_find_channel(&im, im.names[c]) == c, "channel names are unique and found");
        if (im.types[c] == IO_PIXEL_UINT) {
            fuzz_require(im.u32[c].data != NULL && im.f32[c].data == NULL, "a uint channel has one uint plane");
            fuzz_require(im.u32[c].width == im.width && im.u32[c].height == im.height, "plane size");
            for (int y = 0; y < im.height; y++)
                for (int x = 0; x < im.width; x++)
                    h = h * 31u + obs_image_u32_row(&im.u32[c], y)[x];
        } else {
            fuzz_require(im.types[c] == IO_PIXEL_FLOAT, "channel type is FLOAT or UINT");
            fuzz_require(im.f32[c].data != NULL && im.u32[c].data == NULL, "a float channel has one float plane");
            fuzz_require(im.f32[c].width == im.width && im.f32[c].height == im.height, "plane size");
            for (int y = 0; y < im.height; y++)
                for (int x = 0; x < im.width; x++) {
                    uint32_t b;
                    memcpy(&b, &obs_image_f32_row(&im.f32[c], y)[x], 4);
                    h = h * 31u + b;
                }
        }
    }
    for (int i = 0; i < im.attr_count; i++) {
        const io_attr *a = &im.attrs[i];
        fuzz_require(a->name[0] != '\0' && memchr(a->name, '\0', sizeof a->name) != NULL, "attribute names");
        fuzz_require(io_image_find_attr(&im, a->name) != NULL, "attributes are found by name");
        switch (a->type) {
        case IO_ATTR_STRING:
            fuzz_require(a->s != NULL, "a string attribute has its string");
            h += (uint32_t)strlen(a->s);
            break;
        case IO_ATTR_MATRIX44:
            fuzz_require(a->v != NULL && a->n == 16, "a matrix attribute has 16 values");
            /* fall through */
        case IO_ATTR_FLOATS:
            fuzz_require(a->v != NULL && a->n >= 1, "a float-array attribute has its values");
            for (int k = 0; k < a->n; k++) {
                uint32_t b;
                memcpy(&b, &a->v[k], 4);
                h = h * 31u + b;
            }
            break;
        case IO_ATTR_FLOAT:
        case IO_ATTR_INT: break;
        default: fuzz_require(0, "attribute type is known");
        }
    }
    volatile uint32_t sink = h;
    (void)sink;
    io_image_free(&im);
    obs_context_destroy(ctx);
    return 0;
}
