/*
 * A renderer's use of one exported table from C, as its author writes it: the
 * texels from the export's C header (`lobefit export --format inc`), the export's
 * baked GLSL (`lobefit_baked.glsl`: the library with this export's constants, so no
 * uniform to fill), and a compute shader calling lf_cap_exponent_baked. It writes the
 * shader a GL 4.5 / Vulkan renderer compiles to stdout (CI validates it with glslang)
 * and checks the texel array against the header's size; the GL calls a renderer
 * makes with them are in the comments (this example runs without a GL context).
 *
 *     lobefit export --format inc --only cap-exponent --out /tmp/ex
 *     cc -I/tmp/ex gpu/examples/one_family.c -o one_family
 *     ./one_family /tmp/ex/lobefit_baked.glsl > cap.comp && glslangValidator -V cap.comp
 *
 * The lines between `glue:` and `end of glue` are what using the table costs beyond
 * the renderer's own texture, buffer and program setup (CI counts them).
 */
#include <stdio.h>
#include <stdlib.h>

#include "cap-exponent.inc"

/* The renderer's kernel: bindings, and a call of the baked function. */
static const char *KERNEL =
    "layout(local_size_x = 64) in;\n"
    "layout(binding = 0) uniform sampler2D lobefit_table;\n"
    "layout(std430, binding = 1) readonly buffer Alphas { float alpha[]; };\n"
    "layout(std430, binding = 2) writeonly buffer Exponents { float e_cap[]; };\n"
    "void main() {\n"
    "    uint i = gl_GlobalInvocationID.x;\n"
    "    e_cap[i] = lf_cap_exponent_baked(lobefit_table, alpha[i]);\n"
    "}\n";

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: one_family EXPORT_DIR/lobefit_baked.glsl\n");
        return 2;
    }
    /* glue: the texture's size and texels from the header, the baked GLSL. */
    int width = LOBEFIT_CAP_EXPONENT_WIDTH, height = LOBEFIT_CAP_EXPONENT_HEIGHT;
    const float *texels = LOBEFIT_CAP_EXPONENT; /* glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, width, height, 0, GL_RED, GL_FLOAT, texels) */
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        perror(argv[1]);
        return 1;
    }
    printf("#version 450\n");
    for (int c; (c = fgetc(f)) != EOF;) putchar(c);
    fclose(f);
    printf("%s", KERNEL); /* glShaderSource(shader, 1, &that_text, NULL) */
    /* end of glue */

    /* The header's own consistency: a 2D R32F texture of width x height texels. */
    if (LOBEFIT_CAP_EXPONENT_STORAGE_BITS != 32 || LOBEFIT_CAP_EXPONENT_CHANNELS != 1 ||
        (long)width * height != LOBEFIT_CAP_EXPONENT_COUNT || !(texels[0] == texels[0])) {
        fprintf(stderr, "unexpected texture: %d x %d, %d channels\n", width, height, LOBEFIT_CAP_EXPONENT_CHANNELS);
        return 1;
    }
    fprintf(stderr, "cap-exponent: %d x %d R32F texels, shader written\n", width, height);
    return 0;
}
