// A C++17 host of plsr: builds a scene with a parametric light source
// through the C API (via plsr.hpp), renders it and writes EXR and PNG, plus
// the raw RGBA floats (for bit-exact comparison in plsr's test suite).
//
//   host OUT_PREFIX [THREADS]   writes OUT_PREFIX.exr, .png and .rgba
#include "plsr.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>

int main(int argc, char **argv) {
    if (argc < 2) {
        std::cerr << "usage: host OUT_PREFIX [THREADS]\n";
        return 2;
    }
    const std::string out = argv[1];
    const uint32_t threads = argc > 2 ? static_cast<uint32_t>(std::atoi(argv[2])) : 0;
    try {
        plsr::SceneBuilder b;
        const uint32_t floor = b.add_diffuse("floor", {0.7f, 0.7f, 0.7f});
        const uint32_t box = b.add_diffuse("box", {0.2f, 0.4f, 0.8f});
        // A 4 m floor at z = 0 and a 0.5 m box standing on it.
        b.add_mesh({-2, -2, 0, 2, -2, 0, 2, 2, 0, -2, 2, 0}, {0, 1, 2, 0, 2, 3}, floor);
        std::vector<float> v;
        for (int i = 0; i < 8; ++i) {
            v.push_back((i & 1) ? 0.25f : -0.25f);
            v.push_back((i & 2) ? 0.25f : -0.25f);
            v.push_back((i & 4) ? 0.5f : 0.0f);
        }
        b.add_mesh(v, {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
                       2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5},
                   box);
        // The paper's flashlight-like PLS, 1.2 m above, pointing down.
        plsr_pls_params l{};
        l.n[2] = -1.0f;
        l.e1[0] = -0.015f; l.e1[2] = 1.2f;
        l.e2[0] = 0.015f;  l.e2[2] = 1.2f;
        l.alpha1 = 0.0f; l.alpha2 = 1.0f;
        l.d[1] = 0.02f; l.d[2] = 0.02f;
        l.a_deg = 30.0f;
        l.c[0] = 1.0f; l.c[1] = 0.9f; l.c[2] = 0.7f;
        l.b = 4.0f;
        l.brightness_is_radiance = 0;
        plsr::check(plsr_pls_validate(&l));
        b.add_pls(l, 16);
        b.add_point_light({1.5f, -1.5f, 2.0f}, {0.5f, 0.5f, 0.5f});
        b.set_camera({0.0f, -3.0f, 1.5f}, {0.0f, 0.0f, 0.2f}, {0.0f, 0.0f, 1.0f}, 40.0f, 48, 32);
        b.set_render(8, 6, 42);
        const plsr::Scene scene = b.build();
        const plsr::Image img = scene.render(threads);
        img.save_exr(out + ".exr");
        img.save_png(out + ".png");
        std::ofstream raw(out + ".rgba", std::ios::binary);
        raw.write(reinterpret_cast<const char *>(img.rgba()),
                  static_cast<std::streamsize>(sizeof(float) * 4 * img.width() * img.height()));
        std::cout << "plsr " << plsr::version() << ": rendered " << img.width() << "x"
                  << img.height() << " to " << out << ".exr\n";
    } catch (const plsr::Error &e) {
        std::cerr << "plsr error " << e.code() << ": " << e.what() << "\n";
        return 1;
    }
    return 0;
}
