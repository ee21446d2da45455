/* pds.h - PDS, a photon differential splatting renderer for caustics. v0.2.0

   PDS renders caustics with photon differential splatting (Frisvad, Schjoth,
   Erleben, Sporring, "Photon Differential Splatting for Rendering Caustics",
   Computer Graphics Forum 33(6), 2014), next to the methods that paper is
   measured against. This header is the whole public contract: scenes, ray
   queries, images and metrics. The library lives in pds.c; the `pds` tool in
   main.c is built only on what is declared here.

   Quick start (renders nothing yet: loads a scene and shoots one ray):

       #include "pds.h"
       #include <stdio.h>
       int main(void) {
           pds_error err;
           pds_scene *scene = NULL;
           if (pds_scene_load("scenes/demo.scene", &scene, &err) != PDS_OK) {
               fprintf(stderr, "%s\n", pds_error_string(&err));
               return 1;
           }
           pds_ray ray = {{0, 1, 5}, {0, 0, -1}, 0.0, 1e30};
           pds_hit hit;
           if (pds_scene_intersect(scene, &ray, &hit)) printf("t = %g\n", hit.t);
           pds_scene_free(scene);
           return 0;
       }

   Build:   cc -std=c99 -O2 -o pds main.c pds.c -lm -lpthread
            (Windows: x86_64-w64-mingw32-gcc -std=c99 -O2 -o pds.exe main.c
            pds.c, or cl /O2 /std:c11 /Fe:pds.exe main.c pds.c; the small
            core: -DPDS_CORE, see README.md)

   Thread safety: a loaded pds_scene is immutable; any number of threads may
   call the query functions on it at once. Loading, freeing and writing images
   touch only the objects passed in. The library has no global mutable state.

   Determinism: every random number is a pure function of (seed, purpose,
   index); the same inputs give the same output bit for bit, whatever the
   thread count, and whatever shards the render was split into or how often
   it was stopped and continued (pds_render_part, pds_partial_merge).

   Errors: functions that can fail return a pds_status and fill an optional
   pds_error (pass NULL if you do not want it). Input-file errors carry the
   file, line and column; pds_error_string() formats them the way compilers
   do ("scenes/ring.scene:12:7: expected a number after 'ior', got 'glass'").
   The library never prints and never exits. Output files are written to a
   temporary name, "PATH.tmp-PID" (PID: the writing process's id in
   decimal), and renamed, so a failure never leaves a half-written file; a
   program that may be killed while writing removes that name in its signal
   handler (the `pds` tool does).

   License: MIT (see LICENSE).
*/
#ifndef PDS_H
#define PDS_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

#define PDS_VERSION_MAJOR 0
#define PDS_VERSION_MINOR 1
#define PDS_VERSION_PATCH 0
#define PDS_VERSION_STRING "0.2.0"

/* ------------------------------------------------------------------ errors */

typedef enum pds_status {
    PDS_OK = 0,
    PDS_ERR_IO,          /* a file could not be opened, read or written */
    PDS_ERR_PARSE,       /* malformed scene, OBJ, MTL or image file */
    PDS_ERR_NOMEM,       /* an allocation failed */
    PDS_ERR_INVALID_ARG, /* a caller passed a value outside the contract */
    PDS_ERR_LIMIT        /* an input exceeds a documented limit */
} pds_status;

typedef struct pds_error {
    pds_status status;
    char file[512];   /* input file the error is in, "" if none */
    int line, column; /* 1-based; 0 when not known */
    char message[512]; /* what is wrong, without the location */
    char text[1100];   /* "FILE:LINE:COLUMN: message", ready to print */
} pds_error;

const char *pds_status_string(pds_status status);
/* err->text: "FILE:LINE:COLUMN: message" (unknown parts left out). */
const char *pds_error_string(const pds_error *err);

/* ------------------------------------------------------------- documented limits */

#define PDS_MAX_RESOLUTION 16384     /* pixels per image side */
#define PDS_MAX_SPP 65536            /* samples per pixel */
#define PDS_MAX_TESSELLATION 4096    /* segments/rings/grid cells per direction */
#define PDS_MAX_TRIANGLES 50000000   /* triangles in one scene */
#define PDS_MAX_MATERIALS 65536      /* materials in one scene */
#define PDS_MAX_LIGHTS 65536         /* explicit lights in one scene */
#define PDS_MAX_PROFILE_POINTS 4096  /* points in a revolve profile */
#define PDS_MAX_COORD 1e12           /* |coordinate| and any length */
#define PDS_MAX_TEXT_BYTES 67108864  /* a scene or MTL file (64 MiB) */
#define PDS_MAX_OBJ_BYTES 2147483647 /* an OBJ file (2 GiB) */
#define PDS_MAX_LINE_BYTES 4194304   /* one line of a scene, OBJ or MTL file (4 MiB:
                                        an OBJ face of some 500,000 corners) */
#define PDS_MAX_INCLUDE_DEPTH 16     /* scene files nested by `include` */
#define PDS_MAX_INCLUDES 1024        /* `include` statements read in one load (the
                                        files: PDS_MAX_TEXT_BYTES in all) */
#define PDS_MAX_DEFINES 4096         /* variables (`define`) in one scene */
/* Input files must be regular files (not FIFOs, devices or directories);
   a PFM may hold at most PDS_MAX_RESOLUTION^2 pixels. */

/* ------------------------------------------------------------------- math */

typedef struct pds_vec3 { double x, y, z; } pds_vec3;

/* ------------------------------------------------------------------ scene */

typedef enum pds_material_type {
    PDS_MAT_DIFFUSE = 0, /* Lambertian: albedo */
    PDS_MAT_MIRROR,      /* perfect mirror: reflectance */
    PDS_MAT_CONDUCTOR,   /* exact conductor Fresnel: eta + i k per RGB */
    PDS_MAT_DIELECTRIC,  /* exact dielectric Fresnel: ior, Beer absorption */
    PDS_MAT_EMISSIVE,    /* area emitter: radiance (W / m^2 / sr) */
    PDS_MAT_GLOSSY       /* rough conductor: GGX microfacets of roughness
                            alpha with Smith masking-shadowing; Fresnel the
                            constant reflectance, or eta + i k. Glossy is
                            non-specular: a caustic path ends on it */
} pds_material_type;

typedef enum pds_dispersion {
    PDS_DISPERSION_NONE = 0,
    PDS_DISPERSION_CAUCHY,   /* n = A + B / lambda^2, lambda in micrometres */
    PDS_DISPERSION_SELLMEIER /* n^2 = 1 + sum B_i l^2 / (l^2 - C_i), l in um */
} pds_dispersion;

typedef struct pds_material {
    char name[64];
    pds_material_type type;
    double albedo[3];      /* diffuse */
    double tile_size, tile_grout; /* diffuse, optional: grout lines of width
                              tile_grout every tile_size (0: untiled) */
    double grout_albedo[3];/* diffuse: albedo of the grout lines */
    double reflectance[3]; /* mirror */
    double eta[3], k[3];   /* conductor: complex index of refraction per RGB */
    double ior;            /* dielectric: index of the medium behind the surface
                              (the side its normals point away from), at 587.6 nm */
    double absorption[3];  /* dielectric: Beer coefficient of that medium, per scene unit */
    double outside_ior;    /* dielectric: index of the medium in front (default 1: air) */
    double outside_absorption[3]; /* dielectric: Beer coefficient in front (default 0) */
    pds_dispersion dispersion;
    double dispersion_coef[6]; /* Cauchy A,B or Sellmeier B1..B3,C1..C3 */
    double radiance[3];    /* emissive */
    double roughness;      /* glossy: GGX alpha in [0.001, 1] (default 0.2) */
    int fresnel;           /* glossy: F = reflectance (default 1 1 1) times,
                              if 1, the conductor Fresnel of eta + i k
                              (default 0: F constant) */
} pds_material;

typedef enum pds_light_type {
    PDS_LIGHT_POINT = 0, /* position, power (W) */
    PDS_LIGHT_SPOT,      /* position, direction, power (W), cone angles */
    PDS_LIGHT_DIRECTIONAL, /* direction, irradiance (W/m^2), emitter disk or rectangle */
    PDS_LIGHT_DISK,      /* one-sided disk: centre, normal, radius */
    PDS_LIGHT_QUAD,      /* one-sided parallelogram: centre, edge1, edge2 */
    PDS_LIGHT_MESH,      /* triangles of an emissive material */
    PDS_LIGHT_ENVIRONMENT /* at infinity: constant radiance, a CIE clear sky
                            and a sun disk (at most one per scene) */
} pds_light_type;

typedef struct pds_light {
    pds_light_type type;
    pds_vec3 position;   /* point, spot; centre of disk, quad, directional emitter */
    pds_vec3 direction;  /* spot axis, directional travel direction, disk normal */
    pds_vec3 edge1, edge2; /* quad and rectangular directional emitter edges */
    double radius;       /* disk light, disk-shaped directional emitter */
    double cone_inner_deg, cone_outer_deg; /* spot: full power inside inner,
                                             smooth falloff to zero at outer */
    double power[3];     /* W per channel (point, spot, disk, quad, mesh) */
    double irradiance[3];/* W/m^2 per channel perpendicular to direction */
    double radiance[3];  /* W/m^2/sr (disk, quad, mesh) */
    int emitter_shape;   /* directional: 0 = disk, 1 = rectangle */
    int material;        /* mesh light: its emissive material */
    int first_triangle, triangle_count; /* mesh light: its triangles */
    double area;         /* emitting area (m^2); environment: pi R^2 of the
                            scene's bounding sphere (position, radius) */
    /* environment only. Radiance seen along unit direction w (toward the
       sky) is radiance[] (every direction) + sky[] x the CIE clear-sky
       shape (w above the horizon, 1 at the zenith) + ground[] (w below
       the horizon) + the sun's radiance inside its disk. power[] is
       pi R^2 times the integral of that over the sphere. */
    double sky[3];       /* zenith radiance of the clear sky (W/m^2/sr) */
    double ground[3];    /* radiance below the horizon (W/m^2/sr) */
    pds_vec3 up;         /* the zenith (unit) */
    pds_vec3 sun_direction; /* toward the sun (unit) */
    double sun_irradiance[3]; /* at normal incidence (W/m^2): the sun's
                                 radiance is this / (pi sin^2 sun_radius) */
    double sun_radius_deg;    /* angular radius of the sun's disk */
} pds_light;

typedef enum pds_filter { PDS_FILTER_BOX = 0, PDS_FILTER_TENT } pds_filter;

typedef struct pds_camera {
    pds_vec3 position, look_at, up;
    double fov_deg;      /* vertical field of view */
    int width, height;   /* resolution in pixels */
    int spp;             /* samples per pixel */
    pds_filter filter;
    double aperture;     /* thin lens: radius of the lens (scene units);
                            0 = pinhole (everything sharp) */
    double focus_distance; /* thin lens: distance along the view axis of the
                              plane in focus; 0 = |look_at - position| */
} pds_camera;

typedef struct pds_scene pds_scene; /* opaque; immutable once loaded */

/* Load a scene file (format in README.md) and build its BVH. */
pds_status pds_scene_load(const char *path, pds_scene **out, pds_error *err);
/* The same from scene text in memory: `name` stands for the file in error
   messages ("name:LINE:COLUMN: ...") and relative mesh paths are taken
   from name's directory, as for a file of that name. */
pds_status pds_scene_load_string(const char *text, const char *name, pds_scene **out, pds_error *err);
/* Load a bare Wavefront OBJ (with its MTL files) as a scene with a default
   camera looking at its bounds, and build its BVH: the mesh alone, with
   no light (pds_scene_load_ex sets it in a studio, as `pds render` does). */
pds_status pds_scene_load_obj(const char *path, pds_scene **out, pds_error *err);

/* How a file becomes a scene (README "Variables and include", "A bare
   OBJ"): values for the scene's variables, and the studio a bare OBJ is set
   in. pds_load_options_default fills every field. */
typedef enum pds_obj_material {
    PDS_OBJ_MATERIAL_AUTO = 0, /* the OBJ's own MTL materials (white diffuse where none) */
    PDS_OBJ_MATERIAL_DIFFUSE,  /* white diffuse, albedo 0.8 */
    PDS_OBJ_MATERIAL_GLASS,    /* clear glass, ior 1.5: its caustic lands on the ground */
    PDS_OBJ_MATERIAL_METAL     /* polished silver (conductor): a reflected caustic */
} pds_obj_material;

typedef struct pds_define {
    const char *name;  /* a variable the scene declares with `define name DEFAULT` */
    const char *value; /* its value instead of DEFAULT: a number, a name or any text */
} pds_define;

typedef struct pds_load_options {
    const pds_define *defines; /* the command line's -D name=value (default NULL); a
                                  later one of the same name wins; a name the scene
                                  never defines is a warning (pds_scene_warning) */
    int define_count;          /* default 0 */
    int obj_studio;            /* a .obj file: 1 (default) sets it in a studio: a ground
                                  plane under it, a disk light (unless it has emissive
                                  materials) and a camera framing it; 0: the mesh
                                  alone, as pds_scene_load_obj */
    pds_obj_material obj_material; /* the studio's material for the mesh (default AUTO) */
} pds_load_options;

void pds_load_options_default(pds_load_options *lo);
/* Load a scene file, or (by the extension .obj, any case) a bare OBJ, with
   load options (lo NULL: the defaults). pds_scene_load(path) is
   pds_scene_load_ex(path, NULL) for a scene file. */
pds_status pds_scene_load_ex(const char *path, const pds_load_options *lo, pds_scene **out, pds_error *err);
/* pds_scene_load_string with load options (variables; no OBJ). */
pds_status pds_scene_load_string_ex(const char *text, const char *name, const pds_load_options *lo,
                                    pds_scene **out, pds_error *err);
void pds_scene_free(pds_scene *scene);

typedef struct pds_scene_info {
    long triangles, vertices;
    int materials, lights, mesh_lights, shapes;
    long degenerate_dropped; /* zero-area triangles removed while loading */
    pds_vec3 bounds_min, bounds_max;
    int warnings;            /* number of warnings (see pds_scene_warning) */
    size_t memory_bytes;     /* geometry, BVH and light tables */
} pds_scene_info;

void pds_scene_get_info(const pds_scene *scene, pds_scene_info *info);
const char *pds_scene_warning(const pds_scene *scene, int index);
const pds_camera *pds_scene_camera(const pds_scene *scene);
const pds_material *pds_scene_material(const pds_scene *scene, int index);
const pds_light *pds_scene_light(const pds_scene *scene, int index);

/* Index of refraction of a dielectric at a wavelength (nm): its Cauchy or
   Sellmeier law if it has one, else its ior. */
double pds_material_ior(const pds_material *m, double wavelength_nm);

/* One photon as the photon methods emit it from light `index`, driven by
   four uniform numbers in [0,1): where it starts, where it goes, the flux it
   would carry as the only photon of that light (W; divide by the photon
   count), the densities it was sampled with, and the light's emitting area
   and solid angle (the Ae and omega_e of the PDS paper's eqs. 5-6; point
   lights have no area, directional lights no solid angle, the environment
   light the area of the disk across the scene's bounding sphere that its
   photons leave from and no solid angle). Returns 0 if the sample carries
   no flux. */
typedef struct pds_emission {
    pds_vec3 position, direction;
    pds_vec3 normal;        /* emitter surface normal; zero for point and spot lights */
    double flux[3];
    double pdf_position;    /* area density (1 for point and spot lights) */
    double pdf_direction;   /* solid-angle density (1 for directional lights) */
    double area, solid_angle;
} pds_emission;
int pds_scene_emit(const pds_scene *scene, int index, const double u[4], pds_emission *out);

/* ---------------------------------------------------------------- ray queries */

typedef struct pds_ray {
    pds_vec3 origin;
    pds_vec3 dir;     /* need not be unit length; t is in units of |dir| */
    double tmin, tmax;
} pds_ray;

typedef struct pds_hit {
    double t;           /* distance along the ray, in units of |dir| */
    long triangle;      /* index of the triangle hit */
    double u, v;        /* barycentrics: P = (1-u-v) P0 + u P1 + v P2 */
    pds_vec3 position;
    pds_vec3 ng;        /* unit geometric normal, (P1-P0) x (P2-P0) side */
    pds_vec3 ns;        /* unit interpolated shading normal */
    int material;
} pds_hit;

/* Closest hit in (tmin, tmax); returns 1 and fills *hit, or 0. */
int pds_scene_intersect(const pds_scene *scene, const pds_ray *ray, pds_hit *hit);
/* Any hit in (tmin, tmax): 1 if the segment is blocked. */
int pds_scene_occluded(const pds_scene *scene, const pds_ray *ray);

/* ------------------------------------------------------------------ images */

/* Linear RGB, float per channel, rows top to bottom, pixels left to right. */
typedef struct pds_image {
    int width, height;
    float *rgb; /* width * height * 3 floats */
} pds_image;

pds_status pds_image_alloc(pds_image *img, int width, int height);
void pds_image_free(pds_image *img);
/* Portable float map: "PF", little-endian (negative scale), rows bottom to top. */
pds_status pds_image_read_pfm(const char *path, pds_image *img, pds_error *err);
pds_status pds_image_write_pfm(const char *path, const pds_image *img, pds_error *err);
/* 8-bit sRGB PNG: value * 2^exposure_stops, clamped, sRGB transfer curve. */
pds_status pds_image_write_png(const char *path, const pds_image *img,
                               double exposure_stops, pds_error *err);
/* Chooses PFM, PNG or OpenEXR by the file name's extension (.pfm / .png /
   .exr), with the defaults of pds_image_write_options_default but the
   exposure. */
pds_status pds_image_write(const char *path, const pds_image *img,
                           double exposure_stops, pds_error *err);

/* Image metadata: up to PDS_IMAGE_META_MAX text entries, written as
   OpenEXR string attributes, PNG tEXt chunks and a PFM trailer (README
   "Images"), read back from EXR and PFM. A plain value: no allocation.
   Keys: 1-63 printable ASCII characters, no '=', no leading, trailing or
   double spaces (PNG keyword rules); values: printable ASCII. Start from
   a zeroed value (count 0). */
#define PDS_IMAGE_META_MAX 24
#define PDS_IMAGE_META_KEY 64
#define PDS_IMAGE_META_VALUE 1024
typedef struct pds_image_meta {
    int count;
    char key[PDS_IMAGE_META_MAX][PDS_IMAGE_META_KEY];
    char value[PDS_IMAGE_META_MAX][PDS_IMAGE_META_VALUE];
} pds_image_meta;
/* The keys pds writes; PDS_META_KIND is "full" (every light path),
   "caustics-only" (LDS*E paths alone: --caustics-only) or "no-caustics",
   so that a render and a reference of different kinds are told apart. */
#define PDS_META_KIND "pds:kind"
#define PDS_META_KIND_FULL "full"
#define PDS_META_KIND_CAUSTICS "caustics-only"
#define PDS_META_KIND_NO_CAUSTICS "no-caustics"
#define PDS_META_METHOD "pds:method"
/* Adds key = value, or replaces the value of an existing key.
   PDS_ERR_INVALID_ARG for a bad key or value, PDS_ERR_LIMIT when full. */
pds_status pds_image_meta_set(pds_image_meta *meta, const char *key, const char *value);
/* The value of key, or NULL. */
const char *pds_image_meta_get(const pds_image_meta *meta, const char *key);

/* Tone curves for PNG, applied after the exposure and before the sRGB
   transfer curve (README "Images"). */
typedef enum pds_tonemap {
    PDS_TONEMAP_CLAMP = 0, /* clamp to [0,1] */
    PDS_TONEMAP_REINHARD,  /* Reinhard et al. 2002, eq. 3 on luminance: L / (1 + L) */
    PDS_TONEMAP_FILMIC     /* Narkowicz 2015's fit of the ACES filmic curve, per channel */
} pds_tonemap;
/* The curve on one linear value (for PDS_TONEMAP_REINHARD: a luminance). */
double pds_tonemap_curve(pds_tonemap tonemap, double linear);

/* OpenEXR compression, the values of the format's compression attribute. */
typedef enum pds_exr_compression {
    PDS_EXR_NONE = 0, /* uncompressed */
    PDS_EXR_ZIPS = 2, /* deflate, one scanline a block */
    PDS_EXR_ZIP = 3   /* deflate, 16 scanlines a block */
} pds_exr_compression;

typedef struct pds_image_write_options {
    double exposure_stops;               /* PNG: value * 2^stops first; default 0 */
    pds_tonemap tonemap;                 /* PNG: default PDS_TONEMAP_CLAMP */
    pds_exr_compression exr_compression; /* EXR: default PDS_EXR_ZIP */
    const pds_image_meta *meta;          /* written into PNG, EXR and PFM; default NULL */
} pds_image_write_options;
void pds_image_write_options_default(pds_image_write_options *o);
/* Chooses the format by the extension, as pds_image_write. */
pds_status pds_image_write_with(const char *path, const pds_image *img,
                                const pds_image_write_options *o, pds_error *err);
/* OpenEXR: 32-bit float R, G, B scanlines, increasing y. */
pds_status pds_image_write_exr(const char *path, const pds_image *img,
                               pds_exr_compression compression, const pds_image_meta *meta,
                               pds_error *err);
/* OpenEXR scanline files (one part, not tiled or deep) with R, G, B (or Y)
   channels of half, float or uint, compression none, ZIPS or ZIP. meta
   (may be NULL) gets the string attributes. */
pds_status pds_image_read_exr(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err);
/* Reads a PFM or an OpenEXR file, told apart by their first bytes; meta
   (may be NULL) gets the metadata (EXR string attributes, PFM trailer). */
pds_status pds_image_read(const char *path, pds_image *img, pds_image_meta *meta, pds_error *err);

/* RMSE over all pixels and channels of the linear values. */
double pds_image_rmse(const pds_image *a, const pds_image *ref);
/* SSIM (Wang et al. 2004: 11x11 Gaussian window, sigma 1.5, K1 0.01,
   K2 0.03, L 1) of the luminance Y = 0.299 R + 0.587 G + 0.114 B of the
   sRGB-encoded values clamped to [0,1]; mean over the valid window
   positions. Images smaller than 11 pixels on a side use a window clipped
   to the image. Sizes must match (else -1 is returned by the helpers below). */
double pds_image_ssim(const pds_image *a, const pds_image *ref);

typedef struct pds_metrics { double rmse, ssim; } pds_metrics;
pds_status pds_image_compare(const pds_image *a, const pds_image *ref,
                             pds_metrics *out, pds_error *err);
/* The same over the pixels a mask of the same size holds (its first
   channel > 0; `tests/ref_light --complete` writes the pixels a light-
   traced reference holds whole): RMSE over their channels, SSIM over the
   windows centred on them (-1 if none is). NULL: every pixel. An error
   if it holds no pixel. */
pds_status pds_image_compare_masked(const pds_image *a, const pds_image *ref, const pds_image *mask,
                                    pds_metrics *out, pds_error *err);

/* --------------------------------------------------------------- rendering */

typedef enum pds_method {
    PDS_METHOD_PT = 0,     /* unidirectional path tracing, the unbiased reference */
    PDS_METHOD_PREVIEW,    /* eye-light shading: geometry and materials at a glance */
    PDS_METHOD_PDS,        /* photon differential splatting (Frisvad et al. 2014) */
    PDS_METHOD_PM,         /* photon mapping: caustic map, k nearest (Jensen 1996) */
    PDS_METHOD_PDM,        /* photon differential mapping (Schjoth et al. 2007) */
    PDS_METHOD_SPLAT,      /* fixed-radius photon splatting into the eye-path map
                              (Lavignotte & Paulin 2003; Herzog et al. 2007) */
    PDS_METHOD_PPM,        /* progressive photon mapping (Hachisuka et al. 2008) */
    PDS_METHOD_GI,         /* Jensen's two-pass global illumination (Jensen
                              1996): global photon map, shadow photons, final
                              gather, caustics from a caustic method */
    PDS_METHOD_SPM,        /* streamed photon mapping (seed paper 003): streams of a
                              leading photon and associated photons, gathered
                              stream by stream. PDS_PATHS_CAUSTICS_ONLY: its caustic
                              streams; otherwise the paper's whole system, the gi
                              render with global_map PDS_GLOBAL_STREAMS and caustics
                              PDS_METHOD_SPM (streams > 0 also sets the global map's
                              photons: streams x (stream_photons + 1)) */
    PDS_METHOD_ISC         /* image-space caustics (Wyman and Davis 2006): a
                              light-space photon buffer gathered in image space;
                              interactive, approximate; point and spot lights */
} pds_method;

/* How image-space caustics turn the light-space photon buffer into light
   (Wyman and Davis 2006, sect. 3.2). */
typedef enum pds_isc_gather {
    PDS_ISC_POINTS = 0, /* each photon lights the pixel it lands in */
    PDS_ISC_QUADS,      /* caustic polygons between neighbouring photons */
    PDS_ISC_EYE,        /* 7x7 Gaussian gather of photon counts in eye space */
    PDS_ISC_LIGHT       /* the same in light space, projected onto the scene */
} pds_isc_gather;

/* What an animation (pds_render_frames) moves: a turn about the vertical
   line through the camera's look-at point. */
typedef enum pds_orbit {
    PDS_ORBIT_NONE = 0, /* nothing: a static scene */
    PDS_ORBIT_LIGHT,    /* every light (position and direction) */
    PDS_ORBIT_CAMERA    /* the camera's position (it keeps looking at look_at) */
} pds_orbit;

/* Density-estimation kernel of photon mapping (Jensen 1996). */
typedef enum pds_kernel {
    PDS_KERNEL_CONE = 0,   /* w = 1 - d/(k r), k = 1, normalised by 1 - 2/(3k) */
    PDS_KERNEL_GAUSSIAN,   /* Jensen's Gaussian (alpha 0.918, beta 1.953) */
    PDS_KERNEL_NONE        /* uniform disc */
} pds_kernel;

/* What gi's global photon map holds (pds_options.global_map). */
typedef enum pds_global_map {
    PDS_GLOBAL_PHOTONS = 0, /* Jensen 1996: single photons, k nearest per estimate */
    PDS_GLOBAL_STREAMS      /* streamed photon mapping (seed paper 003): streams
                               of a leading photon and stream_photons associated
                               photons landing within stream_radius of it, the
                               k nearest leaders per estimate */
} pds_global_map;

/* Which light paths a render computes. Caustic paths are L S+ D ...: light
   that reaches a non-specular vertex through one or more specular bounces.
   The photon methods compute those; the eye pass computes the rest. For
   every method, ALL = NO_CAUSTICS + CAUSTICS_ONLY (for spm in expectation:
   its full image, a gi render, gathers the caustic streams at gi's eye
   vertices, which take one branch at glass; CAUSTICS_ONLY at both). */
typedef enum pds_paths {
    PDS_PATHS_ALL = 0,
    PDS_PATHS_NO_CAUSTICS,
    PDS_PATHS_CAUSTICS_ONLY
} pds_paths;

/* What a render is doing when it reports progress. */
typedef enum pds_phase {
    PDS_PHASE_EYE = 0,   /* the eye pass (all of a path-traced render) */
    PDS_PHASE_PHOTONS,   /* tracing (and for pds and splat, splatting) photons */
    PDS_PHASE_GATHER     /* pm, pdm, ppm: gathering photons at the eye vertices */
} pds_phase;

/* Progress report: the phase, the fraction of that phase done in [0,1] and
   seconds since the render started. Called from the thread that called
   pds_render only, after each batch of work (an image row, a batch of
   photons, a pass). Return 0 to go on; nonzero to stop: the render finishes
   the batches under way and returns PDS_OK with what it has (stats->partial
   = 1, stats->done_fraction says how much; pds_render_part keeps the exact
   state, to be continued later). */
typedef int (*pds_progress_fn)(void *user, pds_phase phase, double fraction, double elapsed_s);

/* pds_options.photons and .global_photons: the method's own count, which
   pds_options_resolve (below) tells. */
#define PDS_PHOTONS_AUTO (-1L)
/* pds_options.global_k: the map's own (pds_options_resolve) */
#define PDS_GLOBAL_K_AUTO (-1)

typedef struct pds_options {
    pds_method method;  /* default PDS_METHOD_PDS (as the pds tool's) */
    pds_paths paths;    /* default PDS_PATHS_ALL */
    int width, height;  /* 0 = the scene camera's resolution (default 0) */
    int spp;            /* samples per pixel per pass; 0 = the scene camera's (default 0) */
    int threads;        /* 0 = all cores (default 0) */
    unsigned long long seed; /* default 0 */
    int max_depth;      /* longest eye path, in bounces (default 32) */
    int rr_depth;       /* Russian roulette from this bounce on (default 3) */
    int diffuse_bounces; /* eye paths (pt and the photon methods' eye pass)
                           go on past at most this many non-specular
                           vertices; past the last they only collect the
                           emitter their BSDF sample hits (its share of
                           direct light by multiple importance sampling).
                           0: direct light and caustics at the first
                           non-specular vertex seen through any mirrors
                           and glass, no indirect light (the transport of
                           a photon mapper without a global map, such as
                           POV-Ray's). -1 = no limit (default -1). Not gi's
                           eye paths, nor spm's full image (a gi render) */
    double time_s;      /* > 0: render whole passes of spp samples until this
                           many seconds are spent (at least one pass); 0 = one
                           pass (default 0) */
    pds_progress_fn progress; /* default NULL */
    void *progress_user;      /* default NULL */
    /* photon methods */
    long photons;       /* caustic photons to emit; PDS_PHOTONS_AUTO (the
                           default): the method's own, 100000, but for gi's
                           caustic method pixels x samples / 16 within
                           4096..4e6 (pds_options_resolve); with time_s > 0,
                           the photon pass emits batches until the time is
                           spent instead */
    double smoothing;   /* the paper's PDS (progressive 0) and pdm: smoothing
                           parameter s of eqs. 5-6 (default 12; the paper used
                           5 to 40) */
    double plane_tolerance; /* PDS topological-bias guard: eye vertices farther
                           than this times the footprint's major semi-axis from
                           the photon's tangent plane get nothing (default 0.25) */
    double min_aspect;  /* pds, pdm: widen every footprint whose minor semi-axis
                           is shorter than this times its major one to that
                           width, flux unchanged (0 = never, the paper's
                           method; default 0; at most 1). Needle footprints
                           at caustic focal lines otherwise hit single eye
                           vertices with huge weights. */
    int progressive;    /* pds: 1 = progressive PDS: passes of at most
                           pass_photons photons, pass i splatting with
                           s_i = pass_smoothing * i^((pass_alpha - 1)/2),
                           footprints widened by pass_min_aspect and
                           pass_min_width, the image their mean, which
                           converges as photons are added; 0 = the paper's
                           one pass with smoothing, min_aspect and min_width
                           (default 1) */
    long pass_photons;  /* progressive pds: photons per pass, at most (default 16384) */
    int eye_rounds;     /* progressive pds: eye rounds, passes splatting into
                           a new eye pass of spp samples each (the image's
                           eye samples then add up as its photons do).
                           Under a photon budget, R > 1 splits the passes
                           into R runs of consecutive passes (at most one
                           per pass), each with its own eye pass; 0 one
                           run every 1.5 width height spp photons (at
                           least 1); 1: one eye pass. Under a time
                           budget, 0 (default)
                           or R > 1 trace a new eye pass whenever the
                           photon passes since the last one took as long
                           as it did (at most R rounds, 0: no limit) in a
                           render of one shard without teaching views; 1:
                           one eye pass. Default 0. */
    int walls;          /* progressive pds: a footprint that reaches a wall
                           (a surface turned more than 60 degrees from the
                           one the photon landed on, found by four probe
                           rays along the footprint's axes) lights only its
                           own side of it, and the part of its kernel beyond
                           it is folded back (default 1; 0: footprints pass
                           under walls as in the paper) */
    int pass_select;    /* progressive pds: every pixel seen directly (one
                           merged eye vertex in every pass, a pinhole
                           camera, RGB) takes whichever of several estimates
                           of it an independent light tracer's photons (a
                           quarter of each pass's, traced beside it) say is
                           closest: the pass's footprints, the same
                           photons' at half the smoothing and two thirds of
                           the width floor, or the first blurred over one
                           to two and a half pixels within its surface,
                           or the blend of the pass's and one of those
                           with the least error, where the lead clears the
                           validation's noise (default 1; 0: the pass's
                           scale everywhere). It costs a time budget
                           10-25% of its photons. At equal photons never
                           worse on ten scenes against light-traced
                           references; at 3 s from -51% RMSE (the
                           reflection case's cusp) to +13% (the demo and
                           teaching scenes); README "Scales chosen by
                           validation" */
    double pass_alpha;  /* progressive pds: pass i's footprint areas shrink as
                           i^(pass_alpha - 1), in (0, 1] (default 2/3) */
    double pass_smoothing; /* progressive pds: s_1 of the first pass (default 2) */
    double pass_min_aspect; /* progressive pds: as min_aspect (default 0.1) */
    double pass_min_width;  /* progressive pds: as min_width (default 1.5) */
    double min_width;   /* pds: widen every footprint to semi-axes of at least
                           this many times the spacing of the eye samples where
                           it lands (camera distance x the angle between
                           samples, for the tilt), flux unchanged; 0 = never
                           (default 0) */
    int photon_depth;   /* most specular bounces a photon follows (default 16) */
    int split_depth;    /* pds: adaptive splitting (the paper's sect. 5): a
                           photon whose footprint the surface's curvature
                           makes non-linear is re-traced as four sub-photons
                           with half its differentials, at most this many
                           times over (0 = never, the default; at most 8);
                           a sub-photon that is still not linear at the last
                           level keeps at most that normal turn and spread */
    double split_angle; /* pds: split when the surface normal turns by more
                           than this over the footprint (radians), or the
                           direction spreads by more than twice it
                           (default 0.2) */
    /* baselines */
    int k;              /* pm: photons, spm: streams per estimate (default 50) */
    pds_kernel kernel;  /* pm: filter (default PDS_KERNEL_CONE) */
    double max_radius;  /* pm, spm: largest gather radius, 0 = none (default 0) */
    double radius;      /* splat: splat radius; ppm: initial radius; 0 = from
                           the scene and the eye-path map (default 0) */
    double alpha;       /* ppm: radius reduction parameter in (0, 1] (default 0.7) */
    int passes;         /* ppm: photon passes of `photons` each; with time_s > 0
                           passes run until the time is spent (default 10) */
    long max_photons;   /* pdm: most photons gathered per estimate (default 500) */
    long streams;       /* spm: streams nfs; 0 = photons / (stream_photons + 1),
                           the streams that emit as many photons as pm
                           would (default 0); with time_s > 0 streams are
                           emitted until the time is spent instead. spm's
                           full image: nfs > 0 is the global map's too
                           (global_photons = nfs (nfa + 1), at most 1e9);
                           0 leaves it global_photons / (nfa + 1) */
    int stream_photons; /* spm, gi streams: associated photons per stream nfa, 0..10000; a
                           stream is nfa + 1 photons of one nfa+1-th of its
                           energy each (default 10, the paper's comparison) */
    struct pds_debug *debug; /* if not NULL, the teaching views it asks for
                           are made along with the render (see pds_debug;
                           default NULL: none, and no cost) */
    int spectral;       /* 1 = spectral light transport (one wavelength per
                           camera sample and per photon, CIE 1931 film) even
                           without a dispersive material; a scene with a
                           Cauchy or Sellmeier material is always rendered
                           spectrally (default 0) */
    /* gi (Jensen 1996) */
    pds_method caustics; /* gi: the method that adds the caustics seen at the
                           eye path's first non-specular vertex: pds, pm,
                           pdm, splat or ppm, with their own options
                           (default PDS_METHOD_PDS) */
    /* gi; spm's full image uses global_photons, global_k, gather,
       gather_mix, shadow_photons and stream_radius too (its global map is
       always of streams, its caustics spm's) */
    long global_photons; /* gi: photons emitted for the global map;
                           PDS_PHOTONS_AUTO (the default): pixels x samples
                           / 16 within 4096..1e6; spm's full image: 100000
                           (pds_options_resolve) */
    int global_k;       /* gi: nearest photons (streams: leaders) per global
                           radiance estimate, 1..1000; PDS_GLOBAL_K_AUTO
                           (the default): 20 for gi's map of single photons,
                           50 for a map of streams (gi's streams, spm's full
                           image) (pds_options_resolve) */
    int gather;         /* gi: final-gather rays per eye sample, 0..4096
                           (default 1) */
    double gather_mix;  /* gi: share of cosine sampling in the final gather's
                           directions, (0, 1]; the rest follows the global
                           map's incoming photons (default 1 = plain
                           cosine sampling) */
    int shadow_photons; /* gi: 1 = shadow photons decide where shadow rays are
                           needed, 0 = a shadow ray for every light sample
                           (default 0) */
    pds_global_map global_map; /* gi: single photons or streams (default
                           PDS_GLOBAL_PHOTONS); streams: global_photons /
                           (stream_photons + 1) streams of stream_photons + 1
                           photons, global_k leaders per estimate */
    double stream_radius; /* gi with streams, spm's full image: rs, the radius (scene units)
                           around a leader's diffuse hit within which its
                           associated photons are aimed; 0 = 1/16 of the
                           largest side of the scene's bounds (default 0) */
    /* image-space caustics (isc) */
    pds_isc_gather isc_gather; /* default PDS_ISC_EYE */
    int light_resolution; /* side of the light-space photon buffer: side^2
                           photons per light and frame; 0 = the side whose
                           square is nearest `photons` (default 0) */
    int history;        /* temporal filter: frames averaged, this one and the
                           history - 1 before it, 1..64 (default 4, the
                           paper's; 1 = off) */
    pds_orbit orbit;    /* pds_render_frames: what turns (default PDS_ORBIT_LIGHT) */
    double orbit_deg;   /* pds_render_frames: degrees per frame, counter-
                           clockwise seen from above (default 2) */
    int static_lighting; /* pds_render_frames: 1 = the lights and the scene
                           stand still (orbit camera or none; not with a time
                           budget): each light's photon buffer (and the light
                           gather's map) is traced in the first frame, at
                           frame 0's grid offset, and kept; the frames after
                           redo only what depends on the eye (Wyman and Davis's
                           "static lighting"). Each frame is what rendering it
                           alone with this option gives. Stills are the same
                           either way (default 0) */
    double memory_limit; /* bytes: pds_render refuses (PDS_ERR_LIMIT) a render
                           whose pds_render_estimate_get memory exceeds this;
                           0 = this machine's physical memory (default 0) */
    int shard_index, shard_count; /* render only part shard_index (0-based) of
                           shard_count disjoint parts of the render, which
                           pds_partial_merge sums into the image of the whole,
                           bit for bit (see pds_render_part; default 0 of 1) */
} pds_options;

void pds_options_default(pds_options *opt);

/* The options a render of scene with opt uses: each photon count left at
   PDS_PHOTONS_AUTO replaced by the method's own. Caustic photons: 100000;
   gi's, and gi's global photons: one per 16 pixel samples of the render
   (width x height x spp, the camera's where opt leaves them 0), at least
   4096, at most 4e6 caustic and 1e6 global photons, so that the photon
   passes keep pace with the eye pass at few samples and many (README
   "Global illumination"); spm's full image's global map: 100000. Counts
   given stay as they are (and with scene NULL, everything). pds_render
   and its kin resolve opt themselves; call this to know (and print) what
   they use. */
void pds_options_resolve(const pds_scene *scene, pds_options *opt);

/* ------------------------------------------------------- teaching views */

/* What the method did, as pictures (pds_options.debug; `pds render --debug
   NAME`). Each view has a raw value image (width x height: the numbers)
   and a picture (width x (height + PDS_DEBUG_LEGEND_ROWS): the numbers as
   colours, with a colour bar and its scale drawn in the strip below).
   Points are drawn only where the camera sees them: no opaque surface on
   the straight segment from the camera to the point (glass is looked
   through, refraction ignored). */
typedef enum pds_debug_view {
    PDS_DEBUG_FOOTPRINT = 0, /* pds: footprint anisotropy m_a (paper appendix B)
                                per pixel, the mean over the splats weighted by
                                their kernels; value r = 1 - m_a, g = m_a
                                (red = needle, green = round), b = the kernel
                                weight; black where no photon splatted */
    PDS_DEBUG_LANDINGS,      /* pds, splat: photons landed per pixel (each
                                landing point the camera sees, projected
                                straight into the camera) */
    PDS_DEBUG_ELLIPSES,      /* pds: the footprint ellipses of every
                                ellipse_every-th photon (after any widening)
                                whose centre the camera sees, projected
                                straight into the camera and drawn
                                in yellow over the tone-mapped render; value:
                                the ellipses drawn through each pixel */
    PDS_DEBUG_SPLATS,        /* pds, splat: eye vertices each pixel's kernels
                                reached (splat terms added to the pixel) */
    PDS_DEBUG_EYE,           /* photon methods: the eye-path map, every eye
                                vertex the camera sees projected straight
                                into the camera, vertices per pixel */
    PDS_DEBUG_PATHS,         /* photon methods: photons 0..path_photons-1 as
                                OBJ polylines (paths_obj), emission to landing */
    PDS_DEBUG_SCALES,        /* progressive pds: the estimate each pixel took
                                when the pixels chose their scale, in
                                pds_render_stats.scale_pixels' order (0 the
                                passes' scale, 1 the second, 2.. the blurs),
                                one colour each, dimmer where it was blended
                                with the passes'; value: r the estimate, g its
                                weight in the blend (1: alone), r = -1 where
                                the pixel took no part (black) */
    PDS_DEBUG_VIEWS
} pds_debug_view;

#define PDS_DEBUG_LEGEND_ROWS 14 /* rows of the legend strip under a picture */

typedef struct pds_debug {
    unsigned views;       /* (1u << view) for each view wanted (default 0) */
    long ellipse_every;   /* ellipses: photons whose number is a multiple of
                             this; 0 = photons / 100 (default 0) */
    long path_photons;    /* paths: photons recorded (default 100) */
    /* filled by pds_render; free with pds_debug_free */
    pds_image value[PDS_DEBUG_VIEWS];   /* raw numbers (see each view) */
    pds_image picture[PDS_DEBUG_VIEWS]; /* colours and legend, linear RGB in [0,1] */
    double scale_max[PDS_DEBUG_VIEWS];  /* value at the colour bar's right end */
    char *paths_obj;      /* the paths as OBJ text (NUL-terminated) */
    long landings;        /* photons splatted (= stats splatted for pds, splat) */
    long landings_in_frame; /* of those, seen: inside the image, not hidden */
    long ellipses;        /* ellipses drawn */
    long eye_vertices_in_frame; /* eye vertices seen: inside the image, not hidden */
    long paths, path_segments;  /* photon paths and their segments in paths_obj */
} pds_debug;

void pds_debug_init(pds_debug *d);     /* no views, defaults above */
void pds_debug_free(pds_debug *d);     /* the outputs; keeps the request */
const char *pds_debug_view_name(pds_debug_view view); /* "footprint", ... */

/* One vertex of a photon's path as `pds trace-photon` prints it. The
   photon carries two ray differentials (paper eq. 7): axis u is
   (Du x + Dtheta x, Dtheta omega), axis v (Dv x + Dphi x, Dphi omega); at
   emission the positional vectors are Du x, Dv x (eqs. 2-3, 5-6), after
   the first transfer Dtheta x is parallel to Du x (appendix A) and they
   add. fd_* are central finite differences of neighbouring photons,
   started at x +- h Du x, omega +- h Dtheta omega (and so for v) and
   traced by the renderer's own tracing code. */
typedef enum pds_trace_event {
    PDS_TRACE_EMIT = 0, PDS_TRACE_REFLECT, PDS_TRACE_REFRACT, PDS_TRACE_LAND
} pds_trace_event;

typedef struct pds_trace_vertex {
    pds_trace_event event;
    int material;         /* -1 at emission */
    long triangle;        /* -1 at emission */
    pds_vec3 position;    /* x: emission point, or the hit */
    pds_vec3 direction;   /* omega leaving the vertex (arriving, at a landing) */
    pds_vec3 dxdu, dxdv;  /* positional differentials (in the hit's plane) */
    pds_vec3 dwdu, dwdv;  /* directional differentials (perpendicular to omega) */
    double major, minor;  /* footprint ellipse semi-axes (conjugate
                             semi-diameters dxdu/2, dxdv/2) */
    double area;          /* eq. 4: pi/4 |dxdu x dxdv| */
    double flux[3];       /* W */
    int fd_valid;         /* 1 if both neighbours met the same triangles and events */
    pds_vec3 fd_dxdu, fd_dxdv, fd_dwdu, fd_dwdv;
} pds_trace_vertex;

typedef struct pds_trace {
    long photon;
    double smoothing;     /* s of eqs. 5-6 used */
    double photons;       /* N of eqs. 5-6 used */
    double step;          /* h of the finite differences */
    int count;            /* vertices in v */
    pds_trace_vertex *v;  /* free with pds_trace_free */
} pds_trace;

/* Trace caustic photon number `photon` as the paper's PDS emits it
   (opt->smoothing, opt->photons, opt->seed, opt->photon_depth), with the
   finite differences beside its differentials. A photon that misses every
   specular surface has just its emission vertex. */
pds_status pds_trace_photon(const pds_scene *scene, const pds_options *opt, long photon, pds_trace *out,
                            pds_error *err);
void pds_trace_free(pds_trace *t);
const char *pds_method_name(pds_method method);

/* The estimates a pixel seen whole chooses among (pds_render_stats.
   scale_pixels). */
#define PDS_SCALE_ESTIMATES 8

typedef struct pds_render_stats {
    double time_total_s;
    int threads;        /* threads actually used */
    int width, height;
    int spp;            /* samples per pixel actually taken (passes x spp) */
    int passes;
    int spectral;           /* 1 if the render was spectral */
    /* photon methods */
    long photons;           /* photons emitted (including those that missed) */
    long splatted;          /* photons that reached a non-specular surface
                               after >= 1 specular bounce and were splatted
                               (isc: that landed so) */
    long dropped_degenerate;/* photons whose footprint had collapsed */
    long split;             /* pds: photons and sub-photons split in four */
    long eye_vertices;      /* vertices in the eye-path map */
    long eye_samples;       /* camera samples traced, eye rounds' included
                               (a caustics-only render's later rounds skip
                               the pixels its first saw whole) */
    long saturated;         /* terms that overflowed a pixel's exact photon
                               sum (2^128 units, some 10^18 times the scene's
                               typical radiance), which then stays at its
                               largest value; 0 in any sane scene */
    long dropped_invalid;   /* photon terms that were negative, infinite or
                               NaN, dropped */
    long nonfinite;         /* image values that would have been NaN (written
                               as 0) or beyond the float range (written as
                               the largest float) */
    double time_eye_s, time_photons_s; /* the eye pass; the whole photon pass
                               (tracing, and for pds and splat the splats, which
                               go with it batch by batch; for pm, pdm and ppm
                               also the two phases below; for progressive pds
                               the pixels' choice of scale as the image is
                               made: pds_render, not pds_render_part, whose
                               caller adds pds_merge_report.choice_s) */
    double time_map_s;      /* pm, pdm, ppm, spm: building the photon maps; gi:
                               pass 1 (tracing and building the global and
                               shadow maps) plus its caustic method's */
    double time_gather_s;   /* pm, pdm, ppm, spm: gathering at the eye vertices;
                               isc: the gathers (time_photons_s: the
                               light-space buffers, time_eye_s: the eye
                               buffer with its shadow rays) */
    double photons_planned; /* the photon count the photons were weighted for
                               (pds and pdm: N of eqs. 5-6); under a time
                               budget the plan, which the photons emitted may
                               fall short of (the paper's pds: its footprints
                               then cover photons / photons_planned of s^2) */
    double gather_radius;   /* pm, pdm, spm: the search radius a time budget
                               imposed when even a cap of 8 could not end in
                               time (0 = none; see the README's --time) */
    long gather_cap;        /* pm, spm: the k, pdm: the max_photons its gather
                               used: the option's, or under a time budget
                               when the gather with it could not fit the time
                               left, the largest that fits, at least
                               min(8, the option's) */
    size_t map_bytes;       /* pm, pdm, ppm, spm: peak size of the photon map;
                               gi: the global and shadow maps (plus the
                               caustic method's map) */
    /* gi's own figures, also of spm's full image (a gi render): */
    long global_stored;     /* gi: photons stored in the global map */
    long shadow_stored;     /* gi: direct and shadow photons stored */
    long shadow_rays;       /* gi: shadow rays traced */
    long shadow_rays_saved; /* gi: light samples the shadow photons decided
                               without a shadow ray */
    long gather_rays;       /* gi: final-gather rays traced */
    long global_streams;    /* gi with streams: streams stored (a leader's
                               diffuse hit and its associated photons) */
    long streams;           /* spm: streams emitted; photons = streams x
                               (stream_photons + 1) */
    size_t memory_bytes;    /* largest working memory the render held at once
                               (image sums, eye-path map, per-thread images);
                               does not grow with the photon count */
    int partial;            /* 1 when the progress callback stopped the render
                               (or the image is of a shard): not all of it is done */
    double done_fraction;   /* of the whole render's work units (eye rows for
                               pt, photon batches or passes for pds and splat,
                               shards for pm, pdm and ppm) that are done */
    long scale_pixels[PDS_SCALE_ESTIMATES]; /* progressive pds choosing its
                               pixels' scale (pds_options.pass_select): the
                               pixels that took each estimate, [0] the
                               passes' own footprints, [1] the same photons
                               at half the smoothing, [2]-[4] the first
                               blurred by a box of radius 1 once, 1 three
                               times and 2 three times, [5] and [6] by one
                               of radius 1 along the rows alone and along
                               the columns alone, [7] the second blurred
                               by a box of radius 1 once (each alone
                               or blended with [0]); a pixel that was not
                               seen whole in every pass keeps [0] and is
                               counted in none. All 0 in other renders */
    long through_pixels;    /* ... and of the pixels not seen whole in every
                               pass (seen through glass or in a mirror),
                               those that took a blur the halves of the
                               passes chose (the odd-numbered passes'
                               photons against the others') */
} pds_render_stats;

/* What a render will need, from the scene and options alone, before any
   work: an upper bound on the memory it holds at once beyond the scene
   (per eye vertex 264 bytes; a pixel sample records at most 4 when the
   scene has glass (both branches at two surfaces), 1 otherwise, and
   where that many would take over 256 MiB a pilot of 4096 camera samples
   measures their mean instead, counted with a margin of four standard
   errors and a sixteenth of the most, so that bound is an estimate; per
   stored photon 149 bytes for pm and ppm, 176 for pdm; per pixel 60 bytes,
   and for the photon methods 96 more (the partial state's two exact
   sums) plus 48 per thread, 96 per thread in spectral renders; gi: its
   caustic method's needs plus, per global photon, at most 8 global-map
   stores of 149 bytes (with streams 32 more) and 5 shadow stores of 117
   bytes, each counted twice while the threads' arrays are merged, with the
   kd-tree), the
   pixel samples of one eye pass, and the machine's physical memory (0 if
   unknown). With a time budget the photon count is not known in advance
   and counts as 0. */
typedef struct pds_render_estimate {
    double memory_bytes;
    double eye_vertices;    /* photon methods: at most, or the pilot's */
    double stored_photons;  /* pm, pdm: at most; ppm: per pass; spm: streams */
    double samples;         /* pixel samples of one eye pass */
    double available_bytes; /* physical memory, 0 if unknown */
} pds_render_estimate;
pds_status pds_render_estimate_get(const pds_scene *scene, const pds_options *opt,
                                   pds_render_estimate *est, pds_error *err);

/* Render the scene into *out (allocated here; the caller frees it).
   Refuses with PDS_ERR_LIMIT, before any work, a render whose estimated
   memory exceeds opt->memory_limit (or the machine's memory). */
pds_status pds_render(const pds_scene *scene, const pds_options *opt,
                      pds_image *out, pds_render_stats *stats, pds_error *err);

/* A reference for caustics seen directly (tests/ref_light.c makes the
   shipped ones): light tracing, every caustic photon that lands where the
   pinhole camera sees it directly added into the pixel it projects to,
   with no density kernel, so that focal lines are not blurred. The
   caustics-only image at opt's resolution (or the camera's) from
   opt->photons photons (opt->seed, threads, photon_depth, spectral);
   caustics seen through glass or in a mirror are not in it. The same bits
   for any thread count. */
pds_status pds_render_light_traced(const pds_scene *scene, const pds_options *opt, pds_image *out,
                                   pds_error *err);

/* ------------------------------------------------- shards, interrupt, resume */

/* A render is a sum, and its exact state can be kept, continued and merged.
   A pds_partial holds the state of one shard of a render: which of its
   work units are done, the eye pass's pixel values of the rows it owns
   (doubles, each pixel's computed by one shard in sample order) and the
   photon part as exact 128-bit integer sums (order-free), with the scene's
   content hash and every option that shapes the image.

   The work units of shard I of N (0-based):
     pt, preview, and any method with PDS_PATHS_NO_CAUSTICS: image rows
       I, I + N, I + 2N, ...
     pds, splat: photon batches (progressive pds: passes) I, I + N, ...;
       every shard runs the whole eye pass (the eye-path map needs all
       vertices) and keeps the eye image of rows I, I + N, ...
     pm, pdm, ppm, spm: an estimate needs every photon, so every shard
       traces all photons and gathers at the eye vertices of rows I, I + N,
       ... only (the photon part is one unit: done or not).
     gi: its caustics are split as its caustic method's (above); every
       shard builds the whole global and shadow maps (each estimate needs
       all of them) and runs the final gather only for the eye samples of
       the rows it keeps (with pds or splat caustics the other rows' eye
       vertices are recorded without it). spm's full image is a gi render
       with spm caustics, and splits so.
     isc: rows I, I + N, ... of the frame, all or none: its gathers need
       the whole frame, so every shard renders the whole frame in one go
       and keeps its rows.
   A render with a time budget (time_s > 0) cannot be split or continued.
   A spectral render's photon part is two exact sums, of the positive and
   of the negative splats, and is split, continued and merged like an RGB
   one.

   pds_render_part renders (or continues) a part; the progress callback
   may stop it at a batch boundary, and a later call continues it. The
   merged image of all N parts equals pds_render's bit for bit. */
typedef struct pds_partial pds_partial; /* opaque; the caller frees it */

typedef struct pds_partial_info {
    int shard_index, shard_count;
    int width, height;
    pds_method method;
    unsigned long long scene_hash; /* of the loaded scene's geometry, materials,
                                      lights and camera */
    const char *scene_path;        /* as the scene was loaded; owned by the partial */
    int complete;                  /* every unit of the shard is done */
    double done_fraction;          /* of the shard's units */
    long units_done, units_total;  /* the shard's work units (see above) */
    pds_paths paths;               /* the render's light paths (--caustics-only, ...) */
    unsigned long long seed;       /* the render's seed */
    long photons;                  /* the render's photon option */
} pds_partial_info;

/* Render opt's shard (opt->shard_index of opt->shard_count) into *part: a
   new partial if *part is NULL, else continue *part (which must come from
   the same scene and options: refused otherwise). stats as pds_render's,
   for this call's work; stats->partial = 1 while units remain. */
pds_status pds_render_part(const pds_scene *scene, const pds_options *opt, pds_partial **part,
                           pds_render_stats *stats, pds_error *err);
/* The image of n parts of one render: all N shards once each, or with
   allow_subset any of them (units not done are black for the eye rows, and
   the photon part is normalised by the photons actually in it). Refuses
   parts of other scenes, options, shard counts or library versions, and
   duplicated shards; without allow_subset also missing or unfinished ones.
   names (or NULL) name the parts in messages (their files, say). *fraction
   (if not NULL) gets the fraction of the render's work units the parts
   hold. */
pds_status pds_partial_merge(const pds_partial *const *parts, const char *const *names, int n, int allow_subset,
                             pds_image *out, double *fraction, pds_error *err);
/* What the image of a merge holds besides its pixels. */
typedef struct pds_merge_report {
    double fraction;        /* of the render's work units the parts hold */
    long nonfinite;         /* pds_render_stats.nonfinite: values that would
                               have been NaN or beyond the float range */
    long scale_pixels[PDS_SCALE_ESTIMATES]; /* pds_render_stats.scale_pixels: the pixels'
                               choice of scale (all 0 when the parts hold
                               one scale) */
    long through_pixels;    /* pds_render_stats.through_pixels */
    double choice_s;        /* seconds that choice took (0 when the parts
                               hold one scale): part of the photon pass's
                               time, which pds_render counts in
                               time_photons_s */
} pds_merge_report;
/* pds_partial_merge, filling *report (not NULL) as well. */
pds_status pds_partial_merge_report(const pds_partial *const *parts, const char *const *names, int n,
                                    int allow_subset, pds_image *out, pds_merge_report *report, pds_error *err);
/* The partial file (README "Partial files"): versioned little-endian binary,
   written to a temporary name and renamed. */
pds_status pds_partial_write(const char *path, const pds_partial *part, pds_error *err);
pds_status pds_partial_read(const char *path, pds_partial **out, pds_error *err);
void pds_partial_get_info(const pds_partial *part, pds_partial_info *info);
/* The options the part was rendered with (progress, footprint, threads and
   memory_limit at their defaults), to continue it. */
void pds_partial_options(const pds_partial *part, pds_options *opt);
void pds_partial_free(pds_partial *part);
/* The content hash pds_partial_info reports, of a loaded scene. */
unsigned long long pds_scene_hash(const pds_scene *scene);
/* A hash of the options that may change the image: those a partial file
   keeps (every field but threads, progress, progress_user, debug,
   memory_limit, the shard, and static_lighting, which changes animation
   frames only). Equal options give equal hashes; a tool
   that keeps finished renders uses it to know them again. */
unsigned long long pds_options_hash(const pds_options *opt);

/* Called with each frame of pds_render_frames, in order; image belongs to
   the library (copy what you keep); err is never NULL. A status other than
   PDS_OK (with err filled) stops the animation and is returned. */
typedef pds_status (*pds_frame_fn)(void *user, int frame, const pds_image *image, pds_error *err);

/* An animation of `frames` frames (method PDS_METHOD_ISC only): frame f
   turns opt->orbit by f x opt->orbit_deg and shifts the light-space photon
   grid by a sub-texel offset of its own, so the temporal filter
   (opt->history) averages different photons even in a static scene; with
   opt->static_lighting every frame keeps frame 0's photons instead (the
   orbit must not be PDS_ORBIT_LIGHT). stats: photons traced and times
   summed over the frames, passes = frames rendered. */
pds_status pds_render_frames(const pds_scene *scene, const pds_options *opt, int frames, pds_frame_fn fn,
                             void *user, pds_render_stats *stats, pds_error *err);

/* -------------------------------------------------------------- benchmarks */

typedef struct pds_bench_rays_result {
    long triangles;
    double build_s;       /* BVH build time, one thread */
    long rays;            /* rays of each kind */
    double primary_mrays; /* million rays per second, one thread */
    double random_mrays;
    long primary_hits, random_hits;
} pds_bench_rays_result;

/* Ray throughput of a scene's BVH (see README: `pds bench rays`). */
pds_status pds_bench_rays(const char *obj_or_scene_path, long rays,
                          pds_bench_rays_result *out, pds_error *err);

typedef struct pds_bench_filter_result {
    long filters;          /* footprints per method */
    double eq12_mps;       /* million filter matrices per second, eq. 12 */
    double general_mps;    /* the same from the full 3x3 inverse */
    double max_rel_diff;   /* largest relative difference between the two */
} pds_bench_filter_result;

/* PDS paper section 4.2: the 2x3 filter matrix of eq. 12 against the top
   rows of a general 3x3 inverse, on random footprints, one thread. */
pds_status pds_bench_filter(long filters, pds_bench_filter_result *out, pds_error *err);

typedef struct pds_bench_kdtree_result {
    long points, queries;
    double build_s;
    double range_mqps;     /* million range queries per second (about 32 found each) */
    double knn_mqps;       /* million 32-nearest-neighbour queries per second */
    double found_per_query;
} pds_bench_kdtree_result;

/* The eye-path map's kd-tree on uniform random points, one thread. */
pds_status pds_bench_kdtree(long points, pds_bench_kdtree_result *out, pds_error *err);

/* Seconds from a monotonic clock (for callers that time their own work). */
double pds_time_now(void);
int pds_cpu_count(void);

#ifdef __cplusplus
}
#endif
#endif /* PDS_H */
