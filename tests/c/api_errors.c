/* Calls every function of the C API with NULL and invalid arguments and
 * checks the result codes and messages. Exit status 0 on success; on
 * failure prints what went wrong. Built and run by tests/capi.rs. */
#include "plsr.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

/* Whether `message` contains `fragment` (NULL: anything goes). */
static int mentions(const char *message, const char *fragment) {
    return fragment == NULL || strstr(message, fragment) != NULL;
}

#define EXPECT(call, code, fragment)                                              \
    do {                                                                          \
        plsr_result r_ = (call);                                                  \
        const char *m_ = plsr_last_error();                                       \
        if (r_ != (code) || !mentions(m_, fragment)) {                            \
            fprintf(stderr, "%s:%d: %s -> %u (want %u), message \"%s\" (want \"%s\")\n", \
                    __FILE__, __LINE__, #call, (unsigned)r_, (unsigned)(code), m_, \
                    fragment ? fragment : "");                                    \
            failures++;                                                           \
        }                                                                         \
    } while (0)

static plsr_pls_params good_light(void) {
    plsr_pls_params l;
    memset(&l, 0, sizeof l);
    l.n[2] = -1.0f;
    l.e1[0] = -0.01f; l.e1[2] = 1.0f;
    l.e2[0] = 0.01f;  l.e2[2] = 1.0f;
    l.alpha1 = 0.0f; l.alpha2 = 1.0f;
    l.d[1] = 0.01f; l.d[2] = 0.01f;
    l.a_deg = 20.0f;
    l.c[0] = l.c[1] = l.c[2] = 1.0f;
    l.b = 1.0f;
    return l;
}

int main(int argc, char **argv) {
    const char *tmp = argc > 1 ? argv[1] : "/tmp";
    char path[4096];

    if (strlen(plsr_version()) == 0) { fprintf(stderr, "empty version\n"); failures++; }

    /* NULL everywhere a pointer is required. */
    EXPECT(plsr_scene_load(NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "NULL");
    plsr_scene *scene = NULL;
    EXPECT(plsr_scene_load(NULL, &scene), PLSR_ERR_NULL_ARGUMENT, "path");
    EXPECT(plsr_scene_builder_new(NULL), PLSR_ERR_NULL_ARGUMENT, "out");
    EXPECT(plsr_render(NULL, 0, NULL, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "scene");
    EXPECT(plsr_image_size(NULL, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "image");
    EXPECT(plsr_image_save_exr(NULL, "x.exr"), PLSR_ERR_NULL_ARGUMENT, "image");
    EXPECT(plsr_image_save_png(NULL, "x.png", 0.0f, 0), PLSR_ERR_NULL_ARGUMENT, "image");
    if (plsr_image_rgba(NULL) != NULL) { fprintf(stderr, "rgba(NULL) not NULL\n"); failures++; }
    EXPECT(plsr_pls_validate(NULL), PLSR_ERR_NULL_ARGUMENT, "params");
    EXPECT(plsr_pls_transform(NULL, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "params");
    EXPECT(plsr_pls_tessellate(NULL, 8, NULL, 0, NULL, 0, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "params");
    EXPECT(plsr_scene_resolution(NULL, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "scene");
    EXPECT(plsr_scene_builder_build(NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "builder");
    /* Freeing NULL is a no-op. */
    EXPECT(plsr_scene_free(NULL), PLSR_OK, NULL);
    EXPECT(plsr_scene_builder_free(NULL), PLSR_OK, NULL);
    EXPECT(plsr_image_free(NULL), PLSR_OK, NULL);

    /* Bad files: missing, not UTF-8, malformed. */
    snprintf(path, sizeof path, "%s/missing.toml", tmp);
    EXPECT(plsr_scene_load(path, &scene), PLSR_ERR_IO, "missing.toml");
    const char bad_utf8[] = {'/', 't', (char)0xff, 'x', 0};
    EXPECT(plsr_scene_load(bad_utf8, &scene), PLSR_ERR_INVALID_ARGUMENT, "UTF-8");
    snprintf(path, sizeof path, "%s/bad.toml", tmp);
    FILE *f = fopen(path, "w");
    fputs("[render]\nspp = -1\n[camera]\nposition = [0, -3, 0]\nlook_at = [0, 0, 0]\n"
          "up = [0, 0, 1]\nvfov = 40\nresolution = [4, 4]\n", f);
    fclose(f);
    EXPECT(plsr_scene_load(path, &scene), PLSR_ERR_INPUT, "render.spp");
    if (scene != NULL) { fprintf(stderr, "out written on failure\n"); failures++; }
    /* A malformed MTL library (it used to panic inside tobj: PLSR_ERR_PANIC)
       is an input error naming the library and the line. */
    snprintf(path, sizeof path, "%s/m.mtl", tmp);
    f = fopen(path, "w");
    fputs("newmtl a\nKd 0.5 0.5\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/t.obj", tmp);
    f = fopen(path, "w");
    fputs("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n", f);
    fclose(f);
    snprintf(path, sizeof path, "%s/mtl.toml", tmp);
    f = fopen(path, "w");
    fputs("[camera]\nposition = [0, -3, 0]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 40\n"
          "resolution = [4, 4]\n[[shapes]]\ntype = \"obj\"\nfile = \"t.obj\"\n", f);
    fclose(f);
    EXPECT(plsr_scene_load(path, &scene), PLSR_ERR_INPUT, "m.mtl: line 2");
    /* A folder is not a scene file. */
    EXPECT(plsr_scene_load(tmp, &scene), PLSR_ERR_INPUT, "is a folder");

    /* Builder: invalid arguments. */
    plsr_scene_builder *b = NULL;
    EXPECT(plsr_scene_builder_new(&b), PLSR_OK, NULL);
    const float red[3] = {0.8f, 0.1f, 0.1f}, too_bright[3] = {1.5f, 0.0f, 0.0f};
    uint32_t m = 99;
    EXPECT(plsr_scene_builder_add_diffuse(b, NULL, red, &m), PLSR_ERR_NULL_ARGUMENT, "name");
    EXPECT(plsr_scene_builder_add_diffuse(b, "red", NULL, &m), PLSR_ERR_NULL_ARGUMENT, "reflectance");
    EXPECT(plsr_scene_builder_add_diffuse(b, "red", too_bright, &m), PLSR_ERR_INVALID_ARGUMENT, "reflectance");
    EXPECT(plsr_scene_builder_add_diffuse(b, "red", red, &m), PLSR_OK, NULL);
    if (m != 0) { fprintf(stderr, "material index %u\n", m); failures++; }
    EXPECT(plsr_scene_builder_add_diffuse(b, "red", red, &m), PLSR_ERR_INVALID_ARGUMENT, "duplicate");
    plsr_principled pr = {{0.5f, 0.5f, 0.5f}, 2.0f, 0.0f, 0.0f, 0.5f, 0.0f, false};
    EXPECT(plsr_scene_builder_add_principled(b, "p", &pr, NULL), PLSR_ERR_INVALID_ARGUMENT, "roughness");
    const float tri[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    const uint32_t idx[3] = {0, 1, 2}, bad_idx[3] = {0, 1, 7};
    EXPECT(plsr_scene_builder_add_mesh(b, NULL, 3, idx, 1, 0, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "positions");
    EXPECT(plsr_scene_builder_add_mesh(b, tri, 3, bad_idx, 1, 0, NULL, NULL), PLSR_ERR_INVALID_ARGUMENT, "triangle 0");
    EXPECT(plsr_scene_builder_add_mesh(b, tri, 3, idx, 1, 5, NULL, NULL), PLSR_ERR_INVALID_ARGUMENT, "material 5");
    EXPECT(plsr_scene_builder_add_mesh(b, tri, 0, idx, 0, 0, NULL, NULL), PLSR_ERR_INVALID_ARGUMENT, "at least");
    EXPECT(plsr_scene_builder_add_mesh(b, tri, 3, idx, 1, 0, NULL, NULL), PLSR_OK, NULL);
    const float nan3[3] = {0.0f / 0.0f, 0, 0}, one3[3] = {1, 1, 1};
    EXPECT(plsr_scene_builder_add_point_light(b, nan3, one3), PLSR_ERR_INVALID_ARGUMENT, "position");
    plsr_pls_params l = good_light();
    l.a_deg = 120.0f;
    EXPECT(plsr_scene_builder_add_pls(b, &l, 8), PLSR_ERR_INVALID_ARGUMENT, "a");
    const float up[3] = {0, 0, 1}, at[3] = {0, 0, 0}, eye[3] = {0, -3, 1};
    EXPECT(plsr_scene_builder_set_environment(b, "/nonexistent/sky.exr", up, up, 1.0f), PLSR_ERR_INVALID_ARGUMENT, "parallel");
    const float fwd[3] = {0, 1, 0};
    EXPECT(plsr_scene_builder_set_environment(b, "/nonexistent/sky.exr", up, fwd, 1.0f), PLSR_ERR_INPUT, "not found");
    plsr_scene *s2 = NULL;
    EXPECT(plsr_scene_builder_build(b, &s2), PLSR_ERR_INVALID_ARGUMENT, "no camera");
    EXPECT(plsr_scene_builder_set_camera(b, eye, eye, up, 40.0f, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "camera");
    EXPECT(plsr_scene_builder_set_camera(b, eye, at, up, 200.0f, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "field of view");
    EXPECT(plsr_scene_builder_set_camera(b, eye, at, up, 40.0f, 0, 8), PLSR_ERR_INVALID_ARGUMENT, "resolution");
    EXPECT(plsr_scene_builder_set_render(b, 0, 4, 1), PLSR_ERR_INVALID_ARGUMENT, "spp");
    /* A calibrated camera: OpenCV axes (right, down, forward) looking along +y from eye. */
    const float to_world[16] = {1, 0, 0, 0, 0, 0, 1, -3, 0, -1, 0, 1, 0, 0, 0, 1};
    const float scaled[16] = {2, 0, 0, 0, 0, 0, 1, -3, 0, -1, 0, 1, 0, 0, 0, 1};
    const double intr[5] = {8, 8, 3.5, 3.5, 0}, bad_k[5] = {-8, 8, 3.5, 3.5, 0};
    const double d[5] = {-0.2, 0.05, 0.001, 0, 0.01}, tilted[14] = {0};
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, scaled, intr, 1, d, 5, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "to_world");
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, to_world, bad_k, 1, d, 5, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "fx");
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, to_world, intr, 1, tilted, 14, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "tilted");
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, to_world, intr, 2, d, 5, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "fisheye");
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, to_world, intr, 3, d, 0, 8, 8), PLSR_ERR_INVALID_ARGUMENT, "distortion");
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, to_world, intr, 1, NULL, 5, 8, 8), PLSR_ERR_NULL_ARGUMENT, "coefficients");
    EXPECT(plsr_scene_builder_set_calibrated_camera(b, to_world, intr, 1, d, 5, 8, 8), PLSR_OK, NULL);
    EXPECT(plsr_scene_builder_set_render(b, 2, 4, 1), PLSR_OK, NULL);
    EXPECT(plsr_scene_builder_build(b, &s2), PLSR_OK, NULL);
    plsr_scene_free(s2);
    s2 = NULL;
    EXPECT(plsr_scene_builder_set_camera(b, eye, at, up, 40.0f, 8, 8), PLSR_OK, NULL);
    EXPECT(plsr_scene_builder_set_render(b, 2, 4, 1), PLSR_OK, NULL);
    EXPECT(plsr_scene_builder_build(b, &s2), PLSR_OK, NULL);

    /* Wrong handle types and freed handles. */
    EXPECT(plsr_render((const plsr_scene *)b, 1, NULL, NULL, NULL), PLSR_ERR_INVALID_HANDLE, "another type");
    plsr_image *img = NULL;
    EXPECT(plsr_render(s2, 1, NULL, NULL, &img), PLSR_OK, NULL);
    uint32_t w = 0, h = 0;
    EXPECT(plsr_image_size(img, &w, &h), PLSR_OK, NULL);
    if (w != 8 || h != 8 || plsr_image_rgba(img) == NULL) { fprintf(stderr, "image %ux%u\n", w, h); failures++; }
    EXPECT(plsr_image_save_exr(img, "/nonexistent-dir/x.exr"), PLSR_ERR_IO, "nonexistent-dir");
    EXPECT(plsr_image_save_png(img, "/nonexistent-dir/x.png", 0.0f / 0.0f, 0), PLSR_ERR_INVALID_ARGUMENT, "exposure");
    /* The format follows the extension: never OpenEXR bytes named .png. */
    EXPECT(plsr_image_save_exr(img, "/nonexistent-dir/x.png"), PLSR_ERR_INVALID_ARGUMENT, "`.exr`");
    EXPECT(plsr_image_save_png(img, "/nonexistent-dir/x.exr", 0.0f, 0), PLSR_ERR_INVALID_ARGUMENT, "`.png`");
    EXPECT(plsr_image_free(img), PLSR_OK, NULL);
    EXPECT(plsr_image_free(img), PLSR_ERR_INVALID_HANDLE, "not a live handle");
    EXPECT(plsr_image_size(img, &w, &h), PLSR_ERR_INVALID_HANDLE, "not a live handle");
    EXPECT(plsr_scene_free(s2), PLSR_OK, NULL);
    EXPECT(plsr_render(s2, 1, NULL, NULL, &img), PLSR_ERR_INVALID_HANDLE, "not a live handle");
    EXPECT(plsr_scene_builder_free(b), PLSR_OK, NULL);
    int on_stack = 0;
    EXPECT(plsr_scene_free((plsr_scene *)&on_stack), PLSR_ERR_INVALID_HANDLE, "not a live handle");

    /* PLS on its own. */
    l = good_light();
    EXPECT(plsr_pls_validate(&l), PLSR_OK, NULL);
    l.alpha1 = 0.8f; l.alpha2 = 0.2f;
    EXPECT(plsr_pls_validate(&l), PLSR_ERR_INVALID_ARGUMENT, "alpha");
    l = good_light();
    const float shear[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1};
    plsr_pls_params out;
    EXPECT(plsr_pls_transform(&l, shear, &out), PLSR_ERR_INVALID_ARGUMENT, "affine");
    const float move[16] = {1, 0, 0, 2, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    EXPECT(plsr_pls_transform(&l, move, &out), PLSR_OK, NULL);
    if (out.e1[0] != l.e1[0] + 2.0f) { fprintf(stderr, "transform e1 %f\n", out.e1[0]); failures++; }
    size_t nv = 0, nt = 0;
    EXPECT(plsr_pls_tessellate(&l, 0, NULL, 0, NULL, 0, &nv, &nt), PLSR_ERR_INVALID_ARGUMENT, "nf");
    EXPECT(plsr_pls_tessellate(&l, 8, NULL, 0, NULL, 0, &nv, &nt), PLSR_OK, NULL);
    float small[3];
    uint32_t small_i[3];
    EXPECT(plsr_pls_tessellate(&l, 8, small, 3, small_i, 3, &nv, &nt), PLSR_ERR_INVALID_ARGUMENT, "too small");
    float *pos = malloc(sizeof(float) * 3 * nv);
    uint32_t *ind = malloc(sizeof(uint32_t) * 3 * nt);
    EXPECT(plsr_pls_tessellate(&l, 8, pos, 3 * nv, ind, 3 * nt, &nv, &nt), PLSR_OK, NULL);
    for (size_t i = 0; i < 3 * nt; ++i)
        if (ind[i] >= nv) { fprintf(stderr, "index out of range\n"); failures++; break; }
    free(pos);
    free(ind);

    /* Compositing a virtual sphere into a camera frame (added in 0.4.0). */
    snprintf(path, sizeof path, "%s/ar.toml", tmp);
    f = fopen(path, "w");
    fputs("[render]\nspp = 4\n[camera]\nposition = [0, -4, 3]\nlook_at = [0, 0, 0.3]\n"
          "up = [0, 0, 1]\nvfov = 40\nresolution = [16, 12]\n"
          "[[shapes]]\ntype = \"rectangle\"\ntransform = { scale = 3 }\n"
          "[[lights]]\ntype = \"point\"\nposition = [1, -1, 3]\nintensity = [6, 6, 6]\n"
          "[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0.5]\nradius = 0.5\nvirtual = true\n", f);
    fclose(f);
    plsr_scene *ar = NULL;
    EXPECT(plsr_scene_load(path, &ar), PLSR_OK, NULL);
    uint8_t frame[16 * 12 * 3];
    memset(frame, 100, sizeof frame);
    plsr_composite_settings cs = {0, 0, 0.0f, 0, 1};
    plsr_image *composite = NULL;
    float k = 0.0f;
    EXPECT(plsr_composite(NULL, frame, 16, 12, &cs, &composite, &k), PLSR_ERR_NULL_ARGUMENT, "scene");
    EXPECT(plsr_composite(ar, NULL, 16, 12, &cs, &composite, &k), PLSR_ERR_NULL_ARGUMENT, "photo_rgb");
    EXPECT(plsr_composite(ar, frame, 16, 12, NULL, &composite, &k), PLSR_ERR_NULL_ARGUMENT, "settings");
    EXPECT(plsr_composite(ar, frame, 8, 12, &cs, &composite, &k), PLSR_ERR_INVALID_ARGUMENT, "16×12");
    cs.mode = 7;
    EXPECT(plsr_composite(ar, frame, 16, 12, &cs, &composite, &k), PLSR_ERR_INVALID_ARGUMENT, "mode");
    cs.mode = 0;
    cs.exposure = -1.0f;
    EXPECT(plsr_composite(ar, frame, 16, 12, &cs, &composite, &k), PLSR_ERR_INVALID_ARGUMENT, "exposure");
    cs.exposure = 0.0f;
    if (composite != NULL) { fprintf(stderr, "composite written on failure\n"); failures++; }
    EXPECT(plsr_composite(ar, frame, 16, 12, &cs, &composite, &k), PLSR_OK, NULL);
    if (composite != NULL) {
        uint32_t cw = 0, ch = 0;
        EXPECT(plsr_image_size(composite, &cw, &ch), PLSR_OK, NULL);
        const float *px = plsr_image_rgba(composite);
        float matte = 0.0f;
        for (uint32_t i = 0; i < cw * ch; ++i) matte += px[4 * i + 3];
        if (cw != 16 || ch != 12 || matte <= 0.0f || !(k > 0.0f)) {
            fprintf(stderr, "composite %ux%u, matte %g, k %g\n", cw, ch, matte, k);
            failures++;
        }
        EXPECT(plsr_image_free(composite), PLSR_OK, NULL);
    } else {
        fprintf(stderr, "no composite\n");
        failures++;
    }
    EXPECT(plsr_scene_free(ar), PLSR_OK, NULL);

    /* Gradients for a host's own optimiser (added in 0.5.0): find a floor's
       reflectance from a render of it. */
    snprintf(path, sizeof path, "%s/fit.toml", tmp);
    f = fopen(path, "w");
    fputs("[render]\nspp = 4\nmax_depth = 2\n[camera]\nposition = [0, -4, 3]\nlook_at = [0, 0, 0]\n"
          "up = [0, 0, 1]\nvfov = 40\nresolution = [16, 12]\n"
          "[[materials]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [0.3, 0.3, 0.3]\n"
          "[[shapes]]\ntype = \"rectangle\"\nmaterial = \"floor\"\ntransform = { scale = 3 }\n"
          "[[lights]]\ntype = \"point\"\nposition = [1, -1, 3]\nintensity = [6, 6, 6]\n", f);
    fclose(f);
    plsr_scene *fs = NULL;
    EXPECT(plsr_scene_load(path, &fs), PLSR_OK, NULL);
    plsr_parameters *params = NULL;
    const char *bad_pattern[] = {"ceiling.*"};
    EXPECT(plsr_parameters_select(fs, bad_pattern, 1, &params), PLSR_ERR_INVALID_ARGUMENT, "available: floor.reflectance");
    EXPECT(plsr_parameters_select(fs, NULL, 1, &params), PLSR_ERR_NULL_ARGUMENT, "patterns");
    const char *pattern[] = {"floor.reflectance"};
    EXPECT(plsr_parameters_select(fs, pattern, 1, &params), PLSR_OK, NULL);
    size_t count = 0, len = 0, first = 9, size = 0;
    const char *pname = NULL;
    EXPECT(plsr_parameters_size(params, &count, &len), PLSR_OK, NULL);
    EXPECT(plsr_parameters_get(params, 0, &pname, &first, &size), PLSR_OK, NULL);
    EXPECT(plsr_parameters_get(params, 1, &pname, &first, &size), PLSR_ERR_INVALID_ARGUMENT, "1 parameters");
    if (count != 1 || len != 3 || first != 0 || size != 3 || strcmp(pname, "floor.reflectance") != 0) {
        fprintf(stderr, "parameters: %zu %zu %zu %zu %s\n", count, len, first, size, pname);
        failures++;
    }
    float value[3], lower[3], upper[3];
    EXPECT(plsr_parameters_values(params, value, lower, upper, 2), PLSR_ERR_INVALID_ARGUMENT, "3 floats");
    EXPECT(plsr_parameters_values(params, value, lower, upper, 3), PLSR_OK, NULL);
    if (value[1] != 0.3f || lower[1] != 0.0f || upper[1] != 1.0f) {
        fprintf(stderr, "values %g in [%g, %g]\n", value[1], lower[1], upper[1]);
        failures++;
    }
    const float above[3] = {0.6f, 1.5f, 0.6f};
    EXPECT(plsr_parameters_set(fs, params, above, 3), PLSR_ERR_INVALID_ARGUMENT, "must be in [0, 1]");
    /* The target: the floor at 0.6. */
    const float truth[3] = {0.6f, 0.6f, 0.6f};
    EXPECT(plsr_parameters_set(fs, params, truth, 3), PLSR_OK, NULL);
    plsr_image *target_img = NULL;
    plsr_render_settings rs = {256, 2, 99, 0};
    EXPECT(plsr_render_with_settings(fs, &rs, 1, NULL, NULL, &target_img), PLSR_OK, NULL);
    const float *rgba = plsr_image_rgba(target_img);
    float target[16 * 12 * 3];
    for (int i = 0; i < 16 * 12; ++i)
        for (int c = 0; c < 3; ++c) target[3 * i + c] = rgba[4 * i + c];
    EXPECT(plsr_image_free(target_img), PLSR_OK, NULL);
    const float start[3] = {0.3f, 0.3f, 0.3f};
    EXPECT(plsr_parameters_set(fs, params, start, 3), PLSR_OK, NULL);
    plsr_gradient_settings gs = {16, 1, 1, 0};
    double loss = -1.0, first_loss = -1.0;
    float grad[3];
    EXPECT(plsr_loss_gradient(fs, params, target, NULL, 8, 12, &gs, &loss, grad, 3), PLSR_ERR_INVALID_ARGUMENT, "16×12");
    EXPECT(plsr_loss_gradient(fs, params, target, NULL, 16, 12, &gs, NULL, grad, 3), PLSR_ERR_NULL_ARGUMENT, "loss");
    float adjoint[16 * 12 * 3];
    for (int i = 0; i < 16 * 12 * 3; ++i) adjoint[i] = 1.0f;
    EXPECT(plsr_render_gradient(fs, params, adjoint, 16, 12, &gs, grad, 3), PLSR_OK, NULL);
    if (!(grad[0] > 0.0f && grad[1] > 0.0f && grad[2] > 0.0f)) {
        fprintf(stderr, "d(sum of pixels)/d(reflectance) = %g %g %g\n", grad[0], grad[1], grad[2]);
        failures++;
    }
    /* Plain gradient descent, the host's own optimiser. */
    float x[3] = {0.3f, 0.3f, 0.3f};
    for (int it = 0; it < 40; ++it) {
        gs.seed = 2 * (uint64_t)it;
        EXPECT(plsr_loss_gradient(fs, params, target, NULL, 16, 12, &gs, &loss, grad, 3), PLSR_OK, NULL);
        if (it == 0) first_loss = loss;
        for (int c = 0; c < 3; ++c) {
            float step = grad[c] > 0.0f ? 0.02f : (grad[c] < 0.0f ? -0.02f : 0.0f);
            x[c] -= step;
            if (x[c] < 0.0f) x[c] = 0.0f;
            if (x[c] > 1.0f) x[c] = 1.0f;
        }
        EXPECT(plsr_parameters_set(fs, params, x, 3), PLSR_OK, NULL);
    }
    if (fabsf(x[1] - 0.6f) > 0.05f || !(loss < first_loss)) {
        fprintf(stderr, "fitted reflectance %g (want 0.6), loss %g → %g\n", x[1], first_loss, loss);
        failures++;
    }
    EXPECT(plsr_parameters_free(params), PLSR_OK, NULL);
    EXPECT(plsr_parameters_free(params), PLSR_ERR_INVALID_HANDLE, "not a live handle");
    EXPECT(plsr_scene_free(fs), PLSR_OK, NULL);


    /* Denoising a host's own buffers: the defaults (HDR, noisy guides),
     * in place, a normal without an albedo, NaN pixels, sizes below the
     * network's 16×16 (padded). */
    {
        enum { DW = 5, DH = 3, DN = DW * DH * 3 };
        float color[DN], albedo[DN], normal[DN], out[DN];
        for (int i = 0; i < DN; ++i) {
            color[i] = 0.5f + 0.4f * (float)((i * 37) % 11) / 11.0f;
            albedo[i] = 0.5f;
            normal[i] = (i % 3 == 2) ? 1.0f : 0.0f;
        }
        EXPECT(plsr_denoise(DW, DH, color, albedo, normal, NULL, 1, out), PLSR_OK, NULL);
        for (int i = 0; i < DN; ++i)
            if (!(out[i] >= 0.0f && out[i] < 10.0f)) {
                fprintf(stderr, "denoised value %d: %g\n", i, out[i]);
                failures++;
                break;
            }
        float in_place[DN];
        memcpy(in_place, color, sizeof color);
        EXPECT(plsr_denoise(DW, DH, in_place, albedo, normal, NULL, 2, in_place), PLSR_OK, NULL);
        if (memcmp(in_place, out, sizeof out) != 0) {
            fprintf(stderr, "denoising in place or on 2 threads changed the output\n");
            failures++;
        }
        plsr_denoise_settings ds = {1, 1, 0};
        EXPECT(plsr_denoise(DW, DH, color, NULL, normal, &ds, 0, out), PLSR_ERR_INVALID_ARGUMENT, "needs `albedo`");
        EXPECT(plsr_denoise(0, DH, color, NULL, NULL, &ds, 0, out), PLSR_ERR_INVALID_ARGUMENT, "width");
        EXPECT(plsr_denoise(DW, DH, NULL, NULL, NULL, &ds, 0, out), PLSR_ERR_NULL_ARGUMENT, "color");
        EXPECT(plsr_denoise(DW, DH, color, NULL, NULL, &ds, 0, NULL), PLSR_ERR_NULL_ARGUMENT, "output");
        color[4] = NAN;
        color[7] = INFINITY;
        EXPECT(plsr_denoise(DW, DH, color, albedo, normal, NULL, 0, out), PLSR_ERR_INPUT, "2 pixels are NaN or infinite");
        EXPECT(plsr_image_denoise(NULL, 0, 0, NULL), PLSR_ERR_NULL_ARGUMENT, "image");
        EXPECT(plsr_render_denoised(NULL, NULL, 0, 0, NULL, NULL, NULL), PLSR_ERR_NULL_ARGUMENT, "scene");
    }

    if (failures) {
        fprintf(stderr, "%d failure(s)\n", failures);
        return 1;
    }
    printf("all C API error checks passed\n");
    return 0;
}
