/* tests/test_cli.c - the `pds` tool as a user meets it: exit codes, the
   final key=value line, error messages, and no half-written outputs. The
   binary is $PDS_BIN (default ./pds). */
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>

/* Run a shell command line with its stdout captured into out; returns the
   exit status (or -1 if it could not run or was killed). */
static int cli_shell(const char *cmd, char *out, size_t n)
{
    FILE *p;
    size_t len = 0;
    int status;
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

/* Run "pds ARGS" with stdout+stderr captured into out; returns the exit
   status (or -1 if it could not run). */
static int cli_run(const char *args, char *out, size_t n)
{
    const char *bin = getenv("PDS_BIN");
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "%s %s 2>&1", bin ? bin : "./pds", args);
    return cli_shell(cmd, out, n);
}

/* Run a shell command line with stdout into out and stderr into err
   (either may be NULL to drop it); returns the exit status (or -1). */
static int cli_shell_split(const char *cmdline, char *out, size_t n, char *err, size_t m)
{
    char errfile[128], cmd[2300], *dummy = NULL;
    FILE *f;
    size_t len = 0;
    int rc;
    snprintf(errfile, sizeof errfile, "/tmp/pds_cli_stderr_%ld.txt", (long)getpid());
    snprintf(cmd, sizeof cmd, "%s 2>%s", cmdline, errfile);
    if (!out) {
        dummy = (char *)malloc(65536);
        if (!dummy) return -1;
    }
    rc = cli_shell(cmd, out ? out : dummy, out ? n : 65536);
    free(dummy);
    f = fopen(errfile, "rb");
    if (err && m) {
        if (f) len = fread(err, 1, m - 1, f);
        err[len] = '\0';
    }
    if (f) fclose(f);
    remove(errfile);
    return rc;
}

/* "pds ARGS" with stdout into out and stderr into err (either may be NULL). */
static int cli_run_split(const char *args, char *out, size_t n, char *err, size_t m)
{
    const char *bin = getenv("PDS_BIN");
    char cmd[2048];
    snprintf(cmd, sizeof cmd, "%s %s", bin ? bin : "./pds", args);
    return cli_shell_split(cmd, out, n, err, m);
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
    char out[32768];
    CHECK(t, cli_run("--version", out, sizeof out) == 0 && strstr(out, "pds " PDS_VERSION_STRING), "--version: %s", out);
    CHECK(t, cli_run("--help", out, sizeof out) == 0 && strstr(out, "usage: pds"), "--help");
    CHECK(t, cli_run("", out, sizeof out) == 2, "no command is a usage error");
    CHECK(t, cli_run("frobnicate", out, sizeof out) == 2 && strstr(out, "unknown command 'frobnicate'"), "%s", out);
    CHECK(t, cli_run("render", out, sizeof out) == 2 && strstr(out, "render needs a scene file"), "%s", out);
    CHECK(t, cli_run("render scenes/demo.scene --spp 0", out, sizeof out) == 2, "--spp 0");
    CHECK(t, cli_run("render scenes/demo.scene --res 10by10", out, sizeof out) == 2, "--res");
    CHECK(t, cli_run("render scenes/demo.scene --bogus", out, sizeof out) == 2, "unknown option");
    CHECK(t, cli_run("render scenes/demo.scene -o out.jpg", out, sizeof out) == 2 && strstr(out, ".png, .pfm, .exr or .pdsp"), "%s", out);
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

/* A dispersive scene renders spectrally by itself; --spectral asks for it
   in any scene; the final line says so (and says nothing otherwise). */
static void test_cli_spectral_renders_say_so(pds_test_ctx *t)
{
    char out[8192], path[256], args[512];
    snprintf(path, sizeof path, "/tmp/pds_cli_spectral_%ld.pfm", (long)getpid());
    snprintf(args, sizeof args, "render scenes/prism.scene --res 24x16 --spp 1 --photons 2000 -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0 && strstr(cli_last_line(out), " spectral=1 "), "prism: %s", out);
    snprintf(args, sizeof args, "render scenes/demo.scene --res 24x16 --spp 1 --photons 2000 -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0 && !strstr(cli_last_line(out), " spectral="), "demo: %s", out);
    snprintf(args, sizeof args, "render scenes/demo.scene --res 24x16 --spp 1 --photons 2000 --spectral -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0 && strstr(cli_last_line(out), " spectral=1 "), "demo --spectral: %s",
          out);
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
    CHECK(t, !strstr(last, " scale_pixels="), "one sample a pixel: no pixel is seen whole, none chooses: %s", last);
    CHECK(t, cli_file_exists(path) && cli_file_exists(fp), "image and footprint image written");
    remove(path);
    remove(fp);
    /* the pixels' choice of scale (4 samples a pixel: the floor's pixels
       are seen whole): the pixels that took each estimate, at most all of
       them, and the same count in the scales view; every view at once,
       as PFM too (the most files a render writes); with one scale, none */
    snprintf(path, sizeof path, "/tmp/pds_cli_pds_%ld.pfm", (long)getpid());
    snprintf(args, sizeof args,
             "render scenes/refraction.scene --res 32x32 --photons 20000 --caustics-only --debug footprint "
             "--debug landings --debug ellipses --debug splats --debug eye --debug paths --debug scales -o %s",
             path);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render failed: %s", out);
    last = cli_last_line(out);
    {
        const char *sp = strstr(last, " scale_pixels=");
        long a[8] = {0, 0, 0, 0, 0, 0, 0, 0}, all = 0, in_view = 0;
        int v;
        pds_image view = {0, 0, NULL};
        char file[300];
        CHECK(t, sp && sscanf(sp, " scale_pixels=%ld/%ld/%ld/%ld/%ld/%ld/%ld/%ld", &a[0], &a[1], &a[2], &a[3], &a[4],
                              &a[5], &a[6], &a[7]) == 8,
              "final line: %s", last);
        all = a[0] + a[1] + a[2] + a[3] + a[4] + a[5] + a[6] + a[7];
        CHECK(t, all > 512 && all <= 1024, "%ld pixels chose: %s", all, last);
        for (v = 0; v < PDS_DEBUG_VIEWS; v++) {
            const char *name = pds_debug_view_name((pds_debug_view)v);
            snprintf(file, sizeof file, "/tmp/pds_cli_pds_%ld.%s.%s", (long)getpid(), name,
                     v == PDS_DEBUG_PATHS ? "obj" : "png");
            CHECK(t, cli_file_exists(file), "%s not written", file);
            remove(file);
            if (v == PDS_DEBUG_PATHS) continue;
            snprintf(file, sizeof file, "/tmp/pds_cli_pds_%ld.%s.pfm", (long)getpid(), name);
            CHECK(t, cli_file_exists(file), "%s not written", file);
            if (v == PDS_DEBUG_SCALES && pds_image_read(file, &view, NULL, NULL) == PDS_OK) {
                size_t i;
                for (i = 0; i < (size_t)view.width * view.height; i++) in_view += view.rgb[3 * i] >= 0.0f;
                pds_image_free(&view);
            }
            remove(file);
        }
        CHECK(t, in_view == all, "the scales view has %ld pixels that chose, the render %ld", in_view, all);
    }
    snprintf(args, sizeof args, "render scenes/refraction.scene --res 32x32 --photons 20000 --caustics-only "
             "--no-pass-select -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "render failed: %s", out);
    last = cli_last_line(out);
    CHECK(t, !strstr(last, " scale_pixels="), "one scale: %s", last);
    remove(path);
    /* a time budget: photons are counted, not given */
    snprintf(args, sizeof args, "render scenes/refraction.scene --res 16x16 --spp 1 --time 0.5 -o %s", path);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "timed render failed: %s", out);
    last = cli_last_line(out);
    CHECK(t, strstr(last, " photons=") && !strstr(last, " photons=100000 "), "final line: %s", last);
    remove(path);
}

/* --------------------------------------------------------- signals */

/* Does folder dir hold a name with ".tmp-" in it? */
static int cli_dir_has_temp(const char *dir)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    int found = 0;
    if (!d) return 0;
    while ((e = readdir(d)) != NULL)
        if (strstr(e->d_name, ".tmp-")) found = 1;
    closedir(d);
    return found;
}

static void cli_sleep_ms(double ms)
{
    struct timespec ts;
    ts.tv_sec = (time_t)(ms / 1000.0);
    ts.tv_nsec = (long)((ms - 1000.0 * (double)ts.tv_sec) * 1e6);
    nanosleep(&ts, NULL);
}

/* Start PDS_BIN with argv[1..] (argv[0] is replaced), stdout and stderr to
   /dev/null and the signals' default actions (a test run from a background
   shell may have SIGINT ignored, which pds would keep). */
static pid_t cli_spawn(char **argv)
{
    const char *bin = getenv("PDS_BIN");
    pid_t pid;
    argv[0] = (char *)(bin ? bin : "./pds");
    pid = fork();
    if (pid == 0) {
        int fd = open("/dev/null", O_WRONLY);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
        }
        signal(SIGINT, SIG_DFL);
        signal(SIGTERM, SIG_DFL);
        execv(argv[0], argv);
        _exit(127);
    }
    return pid;
}

/* Kill a render while it writes a 12 MB PFM (and once while it renders):
   while it writes, pds dies by that signal; while it renders, it stops
   after the row under way and writes the image so far and its partial
   file, exit status 130. Either way no temporary file is left, and the
   output is either absent or complete. The kill follows the
   temporary file's appearance by 0 to 20 ms, so it lands before, during and
   after the write (the kill at 0 ms is tried again, a few times, until
   one lands during the write). */
static void test_cli_signal_during_write_leaves_no_temporary_file(pds_test_ctx *t)
{
    static const int sigs[] = {SIGTERM, SIGINT};
    static const double delays_ms[] = {-1.0, 0.0, 1.0, 4.0, 20.0}; /* -1: 50 ms after the start */
    char dir[128], out[200], res[] = "1024x1024";
    int si, di, killed_writing = 0, retries = 0;
    snprintf(dir, sizeof dir, "/tmp/pds_cli_sig_%ld", (long)getpid());
    snprintf(out, sizeof out, "%s/big.pfm", dir);
    mkdir(dir, 0777);
    for (si = 0; si < 2; si++)
        for (di = 0; di < (int)(sizeof delays_ms / sizeof delays_ms[0]); di++) {
            char *argv[] = {NULL, "render", "scenes/demo.scene", "--method", "preview", "--res", res, "--spp", "1",
                            "--threads", "2", "-o", out, NULL};
            int status = 0, seen = 0, exited = 0;
            pid_t pid;
            pds_image img = {0, 0, NULL};
            pds_error err;
            remove(out);
            pid = cli_spawn(argv);
            REQUIRE(t, pid > 0, "fork failed");
            if (delays_ms[di] < 0.0) {
                cli_sleep_ms(50.0);
            } else {
                /* wait for the temporary file (or the end) */
                while (!(seen = cli_dir_has_temp(dir)))
                    if (waitpid(pid, &status, WNOHANG) == pid) {
                        exited = 1;
                        break;
                    }
                if (seen) cli_sleep_ms(delays_ms[di]);
            }
            if (!exited) {
                kill(pid, sigs[si]);
                waitpid(pid, &status, 0);
            }
            if (WIFSIGNALED(status)) {
                CHECK(t, WTERMSIG(status) == sigs[si], "died by signal %d, not %d", WTERMSIG(status), sigs[si]);
                if (seen && delays_ms[di] == 0.0) killed_writing++;
            } else if (WIFEXITED(status) && WEXITSTATUS(status) == 130) {
                /* stopped while rendering: the image so far and its partial file */
                char part[260];
                snprintf(part, sizeof part, "%s.pdsp", out);
                CHECK(t, cli_file_exists(out) && cli_file_exists(part), "signal %d, %g ms: exit 130 without %s and %s",
                      sigs[si], delays_ms[di], out, part);
            } else {
                CHECK(t, WIFEXITED(status) && WEXITSTATUS(status) == 0, "neither killed nor finished: status %d",
                      status);
            }
            CHECK(t, !cli_dir_has_temp(dir), "signal %d, %g ms: a temporary file was left in %s", sigs[si],
                  delays_ms[di], dir);
            if (cli_file_exists(out)) {
                CHECK(t, pds_image_read_pfm(out, &img, &err) == PDS_OK && img.width == 1024 && img.height == 1024,
                      "signal %d, %g ms: the output is not a complete image", sigs[si], delays_ms[di]);
                pds_image_free(&img);
            } else if (delays_ms[di] < 0.0) {
                CHECK(t, WIFSIGNALED(status), "stopped while rendering, yet no output");
            }
            /* clean up whatever a failure left, so the next round starts empty */
            {
                DIR *d = opendir(dir);
                struct dirent *e;
                char path[400];
                while (d && (e = readdir(d)) != NULL)
                    if (e->d_name[0] != '.') {
                        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
                        remove(path);
                    }
                if (d) closedir(d);
            }
            /* on a loaded machine the write can end before the kill
               lands: the last signal tries the kill at the temporary
               file's appearance again, up to 8 more times, until one
               lands while the file is being written */
            if (delays_ms[di] == 0.0 && si == 1 && !killed_writing && retries < 8) {
                retries++;
                di--;
            }
        }
    CHECK(t, killed_writing >= 1, "no kill landed while the file was being written in %d tries (the test tested nothing)",
          2 + retries);
    rmdir(dir);
}

/* ------------------------------------------------------------ help */

static void test_cli_every_command_answers_help(pds_test_ctx *t)
{
    static const char *const commands[] = {"render", "sweep", "race", "compare", "merge", "info", "bench", "help"};
    static char out[32768], again[32768], err[4096], args[256], usage[64];
    size_t i;
    for (i = 0; i < sizeof commands / sizeof commands[0]; i++) {
        snprintf(usage, sizeof usage, "usage: pds %s", commands[i]);
        snprintf(args, sizeof args, "%s --help", commands[i]);
        CHECK(t, cli_run_split(args, out, sizeof out, err, sizeof err) == 0, "pds %s: exit status", args);
        CHECK(t, !strncmp(out, usage, strlen(usage)) && strstr(out, "-h, --help") && !err[0],
              "pds %s: stdout %.200s stderr %s", args, out, err);
        snprintf(args, sizeof args, "%s -h", commands[i]);
        CHECK(t, cli_run_split(args, again, sizeof again, NULL, 0) == 0 && !strcmp(out, again), "pds %s", args);
        snprintf(args, sizeof args, "help %s", commands[i]);
        CHECK(t, cli_run_split(args, again, sizeof again, NULL, 0) == 0 && !strcmp(out, again), "pds %s", args);
    }
    /* each its own: render's lists its options, info's does not */
    CHECK(t, cli_run_split("render --help", out, sizeof out, NULL, 0) == 0 && strstr(out, "--photons N") &&
                 !strstr(out, "--methods"), "%s", out);
    CHECK(t, cli_run_split("info --help", out, sizeof out, NULL, 0) == 0 && !strstr(out, "--photons"), "%s", out);
    /* --help wins over whatever else is there: no render, no file opened */
    CHECK(t, cli_run_split("render scenes/demo.scene --bogus --help", out, sizeof out, NULL, 0) == 0 &&
                 !strncmp(out, "usage: pds render", 17), "%s", out);
    CHECK(t, cli_run_split("compare --help", out, sizeof out, NULL, 0) == 0 && !strncmp(out, "usage: pds compare", 18),
          "%s", out);
    /* the overview */
    CHECK(t, cli_run_split("help", out, sizeof out, NULL, 0) == 0 && !strncmp(out, "usage: pds COMMAND", 18), "%s", out);
    CHECK(t, cli_run_split("--help", again, sizeof again, NULL, 0) == 0 && !strcmp(out, again), "pds --help");
    CHECK(t, cli_run_split("-h", again, sizeof again, NULL, 0) == 0 && !strcmp(out, again), "pds -h");
    CHECK(t, cli_run("help rendr", out, sizeof out) == 2 &&
                 !strcmp(out, "pds: unknown command 'rendr' (did you mean 'render'?)\n(run 'pds --help' for usage)\n"),
          "%s", out);
}

/* ------------------------------------------------------ option syntax */

static void test_cli_options_take_joined_values(pds_test_ctx *t)
{
    char out[8192], args[600], png[128];
    const char *last;
    snprintf(png, sizeof png, "/tmp/pds_cli_eq_%ld.png", (long)getpid());
    snprintf(args, sizeof args, "render scenes/demo.scene --method=pt --res=16x12 --spp=1 --seed=3 --output=%s", png);
    CHECK(t, cli_run(args, out, sizeof out) == 0, "%s", out);
    last = cli_last_line(out);
    {
        static const char prefix[] = "render method=pt paths=all width=16 height=12 spp=1 ";
        CHECK(t, !strncmp(last, prefix, strlen(prefix)), "%s", last);
    }
    CHECK(t, strstr(last, png) && cli_file_exists(png), "--output=%s: %s", png, last);
    remove(png);
    /* the harness's own options too: --ref= is taken (the file is missing) */
    snprintf(args, sizeof args, "race scenes/demo.scene --ref=/nonexistent.pfm --methods=pt --photons=3 --res=8x6 "
                                "--output=/tmp/pds_cli_eq_%ld", (long)getpid());
    CHECK(t, cli_run(args, out, sizeof out) == 1 && strstr(out, "/nonexistent.pfm: cannot open"), "%s", out);
    snprintf(args, sizeof args, "sweep scenes/demo.scene --param=spp --values=1,2 --ref=/nonexistent.pfm --method=pt "
                                "--output=/tmp/pds_cli_eq_%ld", (long)getpid());
    CHECK(t, cli_run(args, out, sizeof out) == 1 && strstr(out, "/nonexistent.pfm: cannot open"), "%s", out);
    /* an empty value, and a value for a flag */
    CHECK(t, cli_run("render scenes/demo.scene --photons=", out, sizeof out) == 2 &&
                 strstr(out, "pds render: --photons needs a value\n"), "%s", out);
    CHECK(t, cli_run("render scenes/demo.scene --quiet=yes", out, sizeof out) == 2 &&
                 strstr(out, "pds render: --quiet takes no value, got '--quiet=yes'\n"), "%s", out);
    CHECK(t, cli_run("render scenes/demo.scene --spp=0", out, sizeof out) == 2 &&
                 strstr(out, "pds render: --spp needs a whole number from 1 to 65536, got '0'\n"), "%s", out);
}

static void test_cli_counts_take_exponents_and_suffixes(pds_test_ctx *t)
{
    static const char *const good[][2] = {
        {"--photons 2.5k", " photons=2500 "}, {"--photons 1e3", " photons=1000 "}, {"--photons=3K", " photons=3000 "},
        {"--photons 0.002M", " photons=2000 "}, {"--photons 1.5e3 --method pm --k 1e1", " k=10 "},
    };
    static const char *const bad[][2] = {
        {"--photons 1.5", "--photons needs a whole number of 0 or more, got '1.5'"},
        {"--photons 2x", "--photons needs a whole number of 0 or more, got '2x'"},
        {"--photons -1k", "--photons needs a whole number of 0 or more, got '-1k'"},
        {"--photons 0x10", "--photons needs a whole number of 0 or more, got '0x10'"},
        {"--photons 1e30", "--photons needs a whole number of 0 or more, got '1e30'"},
        {"--spp 100k", "--spp needs a whole number from 1 to 65536, got '100k'"},
        {"--k 2G", "--k needs a whole number from 1 to 1000000, got '2G'"},
        {"--passes 1.5k5", "--passes needs a whole number from 1 to 1000000, got '1.5k5'"},
    };
    char out[8192], args[600], png[128];
    size_t i;
    snprintf(png, sizeof png, "/tmp/pds_cli_count_%ld.png", (long)getpid());
    for (i = 0; i < sizeof good / sizeof good[0]; i++) {
        snprintf(args, sizeof args, "render tests/golden/glass.scene %s --res 8x6 --spp 1 -o %s", good[i][0], png);
        CHECK(t, cli_run(args, out, sizeof out) == 0 && strstr(cli_last_line(out), good[i][1]), "%s: %s", args, out);
    }
    remove(png);
    for (i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        char expect[256];
        snprintf(args, sizeof args, "render tests/golden/glass.scene %s -o %s", bad[i][0], png);
        snprintf(expect, sizeof expect, "pds render: %s\n", bad[i][1]);
        CHECK(t, cli_run(args, out, sizeof out) == 2 && strstr(out, expect), "%s: %s", args, out);
    }
    CHECK(t, !cli_file_exists(png), "no output after usage errors");
}

/* ------------------------------------------------------- did you mean */

static void test_cli_near_miss_names_get_a_suggestion(pds_test_ctx *t)
{
    static const char *const cases[][2] = {
        {"render x.scene --photon 10", "pds render: unknown option '--photon' (did you mean '--photons'?)\n"
                                       "(run 'pds render --help' for usage)\n"},
        {"render x.scene --smothing=8", "pds render: unknown option '--smothing' (did you mean '--smoothing'?)\n"},
        {"render x.scene --max 3", "pds render: unknown option '--max' (did you mean '--max-radius', '--max-photons' or "
                                   "'--max-depth'?)\n"},
        {"render x.scene --bogus", "pds render: unknown option '--bogus'\n"},
        {"render x.scene --method pdss", "pds render: unknown method 'pdss' (did you mean 'pds'?)\n"},
        {"render x.scene --kernel gausian", "--kernel knows cone, gaussian and none, got 'gausian' (did you mean "
                                            "'gaussian'?)\n"},
        {"render x.scene --method gi --global-map stream", "pds render: --global-map takes photons or streams, got "
                                                           "'stream' (did you mean 'streams'?)\n"},
        {"race x.scene --ref r.pfm --methds pt", "pds race: unknown option '--methds' (did you mean '--methods'?)\n"},
        {"race x.scene --ref r.pfm --methods pt,pmm --photons 3", "pds race: unknown method 'pmm' (did you mean 'pm', "
                                                                  "'pdm' or 'ppm'?)\n"},
        {"race x.scene --ref r.pfm --methods pm:kernal=cone --photons 3",
         "pds race: --methods: unknown option 'kernal' for pm (did you mean 'kernel'?)\n"},
        {"sweep x.scene --pram spp", "pds sweep: unknown option '--pram' (did you mean '--param'?)\n"},
        {"sweep x.scene --param smothing --values 1 --ref r.pfm", "got 'smothing' (did you mean 'smoothing'?)\n"},
        {"rendr x.scene", "pds: unknown command 'rendr' (did you mean 'render'?)\n"},
        {"bench kdtre", "pds bench: unknown benchmark 'kdtre' (did you mean 'kdtree'?)\n"},
        {"bench budget --runs 0", "pds bench: bench budget: --runs needs a whole number from 1 to 99, got '0'\n"},
        {"bench budget --methods pds,pmm", "bench budget: unknown method 'pmm' (pds, paper, pm, pdm, splat, ppm, spm, gi)"},
        {"bench budget --times 1,x", "bench budget: --times needs up to 8 seconds from 0.01 to 3600, got '1,x'"},
        {"bench pass --photons 5", "pds bench: bench pass: --photons needs a count from 1000 to 1e8, got '5'\n"},
        {"bench pass --photon 1M", "pds bench: bench pass: unknown option '--photon' (--photons)\n"},
    };
    char out[8192];
    size_t i;
    for (i = 0; i < sizeof cases / sizeof cases[0]; i++)
        CHECK(t, cli_run(cases[i][0], out, sizeof out) == 2 && strstr(out, cases[i][1]), "pds %s:\n%s", cases[i][0],
              out);
}

/* ---------------------------------------------------- render's checks */

/* A bad -o is found before the scene is even read. */
static void test_cli_render_checks_the_output_before_rendering(pds_test_ctx *t)
{
    char out[8192], args[600], file[128], dir[128];
    snprintf(file, sizeof file, "/tmp/pds_cli_plain_%ld", (long)getpid());
    snprintf(dir, sizeof dir, "/tmp/pds_cli_dir_%ld.png", (long)getpid());
    CHECK(t, cli_run("render /nonexistent.scene -o /nonexistent-dir/x.png", out, sizeof out) == 1 &&
                 !strcmp(out, "/nonexistent-dir/x.png: cannot write: /nonexistent-dir: No such file or directory\n"),
          "%s", out);
    scene_tmp_write(file, sizeof file, "plain", "not a folder\n");
    snprintf(args, sizeof args, "render /nonexistent.scene -o %s/x.png", file);
    CHECK(t, cli_run(args, out, sizeof out) == 1 && strstr(out, "is not a folder\n") && !strstr(out, "nonexistent.scene"),
          "%s", out);
    remove(file);
    mkdir(dir, 0777);
    snprintf(args, sizeof args, "render /nonexistent.scene -o %s", dir);
    CHECK(t, cli_run(args, out, sizeof out) == 1 && strstr(out, ": cannot write: it is a folder\n"), "%s", out);
    rmdir(dir);
    /* the footprint image beside it is checked too; a good -o reaches the scene */
    CHECK(t, cli_run("render /nonexistent.scene -o /tmp/x.png", out, sizeof out) == 1 &&
                 strstr(out, "/nonexistent.scene: cannot open"), "%s", out);
}

static void test_cli_render_shows_the_scene_warnings_unless_quiet(pds_test_ctx *t)
{
    char scene[256], png[128], args[600], err[4096], expect[400];
    scene_tmp_write(scene, sizeof scene, "dark.scene", "camera { resolution 8 6 spp 1 }\nsphere { radius 1 }\n");
    snprintf(png, sizeof png, "/tmp/pds_cli_warn_%ld.png", (long)getpid());
    snprintf(expect, sizeof expect, "pds render: warning: %s: the scene has no light\n", scene);
    snprintf(args, sizeof args, "render %s --method preview -o %s", scene, png);
    CHECK(t, cli_run_split(args, NULL, 0, err, sizeof err) == 0 && !strcmp(err, expect), "stderr: %s", err);
    snprintf(args, sizeof args, "render %s --method preview --quiet -o %s", scene, png);
    CHECK(t, cli_run_split(args, NULL, 0, err, sizeof err) == 0 && !err[0], "--quiet, stderr: %s", err);
    remove(png);
    remove(scene);
}

/* --------------------------------------------------------- progress */

/* --progress into a file: a line every 2 seconds and a last one at 100%,
   newline-terminated, no carriage returns; the elapsed time never goes
   back (one clock for the whole command) and the ETA knows the budget. */
static void test_cli_progress_off_a_terminal_is_a_few_lines(pds_test_ctx *t)
{
    char png[128], args[600], err[8192], *line;
    int lines = 0;
    double last_elapsed = -1.0;
    snprintf(png, sizeof png, "/tmp/pds_cli_progress_%ld.png", (long)getpid());
    snprintf(args, sizeof args, "render scenes/refraction.scene --res 32x32 --spp 1 --time 2.5 --progress -o %s", png);
    CHECK(t, cli_run_split(args, NULL, 0, err, sizeof err) == 0, "render failed: %s", err);
    remove(png);
    CHECK(t, strlen(err) < 400 && !strchr(err, '\r') && strlen(err) > 0 && err[strlen(err) - 1] == '\n',
          "%lu bytes: %s", (unsigned long)strlen(err), err);
    for (line = err; *line; line = strchr(line, '\n') + 1) {
        const char *e = strstr(line, "elapsed "), *eta = strstr(line, "ETA ");
        double elapsed = e ? atof(e + 8) : -1.0;
        char *nl = strchr(line, '\n');
        lines++;
        CHECK(t, e && elapsed >= last_elapsed, "elapsed went back: %s", err);
        CHECK(t, !eta || eta > nl || atof(eta + 4) <= 2.5, "an ETA past the budget: %s", err);
        last_elapsed = elapsed;
        if (!strchr(nl + 1, '\n')) CHECK(t, strstr(line, "100%") && elapsed >= 2.5, "last line: %s", line);
    }
    CHECK(t, lines >= 2 && lines <= 4, "%d lines in 2.5 s: %s", lines, err);
}

/* ------------------------------------------------------ the test runner */

/* A passing run prints nothing but its count (the golden self-test writes
   failure images on purpose, silently); PDS_TEST_VERBOSE=1 names each test
   on stderr as it starts. Runs this very program on one test. */
static void test_cli_test_runner_is_quiet_on_success(pds_test_ctx *t)
{
    char self[1024], cmd[1200], out[4096], err[4096];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    REQUIRE(t, n > 0, "cannot find this program (/proc/self/exe)");
    self[n] = '\0';
    snprintf(cmd, sizeof cmd, "PDS_TEST_VERBOSE=0 %s golden_failure_writes_actual", self);
    CHECK(t, cli_shell_split(cmd, out, sizeof out, err, sizeof err) == 0 && !strcmp(out, "1 passed, 0 failed\n") &&
                 !err[0], "stdout: %s stderr: %s", out, err);
    snprintf(cmd, sizeof cmd, "PDS_TEST_VERBOSE=1 %s golden_failure_writes_actual", self);
    CHECK(t, cli_shell_split(cmd, out, sizeof out, err, sizeof err) == 0 && !strcmp(out, "1 passed, 0 failed\n") &&
                 !strcmp(err, "[  1/1] golden_failure_writes_actual_and_difference\n"),
          "stdout: %s stderr: %s", out, err);
}

static const pds_test_case tests_cli[] = {
    {"cli_exit_codes_follow_the_contract", test_cli_exit_codes_follow_the_contract},
    {"cli_spectral_renders_say_so", test_cli_spectral_renders_say_so},
    {"cli_render_writes_the_image_and_a_final_line", test_cli_render_writes_the_image_and_a_final_line},
    {"cli_bad_scene_reports_location_and_writes_nothing", test_cli_bad_scene_reports_location_and_writes_nothing},
    {"cli_info_describes_the_scene", test_cli_info_describes_the_scene},
    {"cli_pds_reports_photons_and_writes_the_footprint_image", test_cli_pds_reports_photons_and_writes_the_footprint_image},
    {"cli_signal_during_write_leaves_no_temporary_file", test_cli_signal_during_write_leaves_no_temporary_file},
    {"cli_every_command_answers_help", test_cli_every_command_answers_help},
    {"cli_options_take_joined_values", test_cli_options_take_joined_values},
    {"cli_counts_take_exponents_and_suffixes", test_cli_counts_take_exponents_and_suffixes},
    {"cli_near_miss_names_get_a_suggestion", test_cli_near_miss_names_get_a_suggestion},
    {"cli_render_checks_the_output_before_rendering", test_cli_render_checks_the_output_before_rendering},
    {"cli_render_shows_the_scene_warnings_unless_quiet", test_cli_render_shows_the_scene_warnings_unless_quiet},
    {"cli_progress_off_a_terminal_is_a_few_lines", test_cli_progress_off_a_terminal_is_a_few_lines},
    {"cli_test_runner_is_quiet_on_success", test_cli_test_runner_is_quiet_on_success},
};
