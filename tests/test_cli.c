/* tests/test_cli.c - the `pds` tool as a user meets it: exit codes, the
   final key=value line, error messages, and no half-written outputs. The
   binary is $PDS_BIN (default ./pds). */
#include <sys/wait.h>

/* Run "pds ARGS" with stdout+stderr captured into out; returns the exit
   status (or -1 if it could not run). */
static int cli_run(const char *args, char *out, size_t n)
{
    const char *bin = getenv("PDS_BIN");
    char cmd[2048];
    FILE *p;
    size_t len = 0;
    int status;
    snprintf(cmd, sizeof cmd, "%s %s 2>&1", bin ? bin : "./pds", args);
    p = popen(cmd, "r");
    if (!p) return -1;
    while (len + 1 < n) {
        size_t r = fread(out + len, 1, n - 1 - len, p);
        if (r == 0) break;
        len += r;
    }
    out[len] = '\0';
    status = pclose(p);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/* The last non-empty line of text. */
static const char *cli_last_line(char *text)
{
    size_t n = strlen(text);
    while (n && text[n - 1] == '\n') text[--n] = '\0';
    while (n && text[n - 1] != '\n') n--;
    return text + n;
}

static int cli_file_exists(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f) fclose(f);
    return f != NULL;
}

static void test_cli_exit_codes_follow_the_contract(pds_test_ctx *t)
{
    char out[8192];
    CHECK(t, cli_run("--version", out, sizeof out) == 0 && strstr(out, "pds " PDS_VERSION_STRING), "--version: %s", out);
    CHECK(t, cli_run("--help", out, sizeof out) == 0 && strstr(out, "usage: pds"), "--help");
    CHECK(t, cli_run("", out, sizeof out) == 2, "no command is a usage error");
    CHECK(t, cli_run("frobnicate", out, sizeof out) == 2 && strstr(out, "unknown command 'frobnicate'"), "%s", out);
    CHECK(t, cli_run("render", out, sizeof out) == 2 && strstr(out, "render needs a scene file"), "%s", out);
    CHECK(t, cli_run("render scenes/demo.scene --spp 0", out, sizeof out) == 2, "--spp 0");
    CHECK(t, cli_run("render scenes/demo.scene --res 10by10", out, sizeof out) == 2, "--res");
    CHECK(t, cli_run("render scenes/demo.scene --bogus", out, sizeof out) == 2, "unknown option");
    CHECK(t, cli_run("render scenes/demo.scene -o out.jpg", out, sizeof out) == 2 && strstr(out, ".png or .pfm"), "%s", out);
    CHECK(t, cli_run("compare a.pfm", out, sizeof out) == 2, "compare arity");
    CHECK(t, cli_run("render /nonexistent.scene -o /tmp/x.png", out, sizeof out) == 1 &&
                 strstr(out, "/nonexistent.scene: cannot open"), "%s", out);
}

static void test_cli_render_writes_the_image_and_a_final_line(pds_test_ctx *t)
{
    char out[8192], path[256], args[512];
    const char *last;
    snprintf(path, sizeof path, "/tmp/pds_cli_%ld.png", (long)getpid());
    snprintf(args, sizeof args, "render scenes/demo.scene --method pt --res 64x48 --spp 1 --threads 2 -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render failed: %s", out);
    last = cli_last_line(out);
    {
        static const char prefix[] = "render method=pt paths=all width=64 height=48 spp=1 passes=1 time_total=";
        CHECK(t, strncmp(last, prefix, strlen(prefix)) == 0, "final line: %s", last);
    }
    CHECK(t, strstr(last, " threads=2 ") != NULL, "threads in final line: %s", last);
    CHECK(t, cli_file_exists(path), "output written");
    remove(path);
}

static void test_cli_bad_scene_reports_location_and_writes_nothing(pds_test_ctx *t)
{
    char out[8192], scene[256], png[256], args[600], expect[512];
    scene_tmp_write(scene, sizeof scene, "bad_cli.scene", "camera { fov 40 }\nsphere { radius -2 }\n");
    snprintf(png, sizeof png, "/tmp/pds_cli_bad_%ld.png", (long)getpid());
    remove(png);
    snprintf(args, sizeof args, "render %s -o %s", scene, png);
    CHECK(t, cli_run(args, out, sizeof out) == 1, "exit status");
    snprintf(expect, sizeof expect, "%s:2:17: 'radius' must be positive, got -2\n", scene);
    CHECK(t, strcmp(out, expect) == 0, "stderr: %s", out);
    CHECK(t, !cli_file_exists(png), "no output file after a failure");
    remove(scene);
}

static void test_cli_info_describes_the_scene(pds_test_ctx *t)
{
    char out[8192];
    const char *last;
    CHECK(t, cli_run("info scenes/demo.scene", out, sizeof out) == 0, "info failed: %s", out);
    CHECK(t, strstr(out, "material    gold             conductor") != NULL, "material listing: %s", out);
    last = cli_last_line(out);
    CHECK(t, strncmp(last, "info triangles=", 15) == 0 && strstr(last, " lights=1 mesh_lights=1 "), "final line: %s", last);
}


static void test_cli_pds_reports_photons_and_writes_the_footprint_image(pds_test_ctx *t)
{
    char out[8192], path[256], fp[256], args[600];
    const char *last;
    snprintf(path, sizeof path, "/tmp/pds_cli_pds_%ld.png", (long)getpid());
    snprintf(fp, sizeof fp, "/tmp/pds_cli_pds_%ld.footprint.png", (long)getpid());
    snprintf(args, sizeof args, "render scenes/refraction.scene --res 32x32 --spp 1 --photons 5000 --debug footprint -o %s",
             path);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render failed: %s", out);
    last = cli_last_line(out);
    {
        static const char prefix[] = "render method=pds paths=all width=32 height=32 spp=1 photons=5000 splatted=";
        CHECK(t, strncmp(last, prefix, strlen(prefix)) == 0, "final line: %s", last);
    }
    CHECK(t, strstr(last, " dropped_degenerate=") && strstr(last, " eye_vertices=1024 ") && strstr(last, " time_eye=") &&
                 strstr(last, " time_photons="), "final line: %s", last);
    CHECK(t, cli_file_exists(path) && cli_file_exists(fp), "image and footprint image written");
    remove(path);
    remove(fp);
    /* a time budget: photons are counted, not given */
    snprintf(args, sizeof args, "render scenes/refraction.scene --res 16x16 --spp 1 --time 0.5 -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "timed render failed: %s", out);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " photons=") && !strstr(last, " photons=100000 "), "final line: %s", last);
    remove(path);
}

static const pds_test_case tests_cli[] = {
    {"cli_exit_codes_follow_the_contract", test_cli_exit_codes_follow_the_contract},
    {"cli_render_writes_the_image_and_a_final_line", test_cli_render_writes_the_image_and_a_final_line},
    {"cli_bad_scene_reports_location_and_writes_nothing", test_cli_bad_scene_reports_location_and_writes_nothing},
    {"cli_info_describes_the_scene", test_cli_info_describes_the_scene},
    {"cli_pds_reports_photons_and_writes_the_footprint_image", test_cli_pds_reports_photons_and_writes_the_footprint_image},
};
