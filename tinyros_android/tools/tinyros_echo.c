/* tinyros_echo: a smoke test a person can run.
 *   rosrun mobile_device_sim tinyros_echo /mobile_device/image_raw
 * prints one line a second, e.g. "640x480 rgb8 29.9 fps". */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "tinyros/camera_shim.h"
#include "tinyros/tinyros.h"

static volatile sig_atomic_t g_stop = 0;
static void on_signal(int sig) { (void)sig; g_stop = 1; }

static double mono_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}
static double wall_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (double)ts.tv_sec + ts.tv_nsec * 1e-9;
}

static void usage(void)
{
    fprintf(stderr,
            "usage: tinyros_echo [options] [topic]       (default topic " TR_DEFAULT_TOPIC ")\n"
            "  --master URI      ROS master (default $ROS_MASTER_URI)\n"
            "  --caller-id ID    node name (default /tinyros_echo_<pid>)\n"
            "  --max-bytes N     reject messages longer than N bytes (default 64 MiB)\n"
            "  -n N              exit after N frames (status 2 if the time limit comes first)\n"
            "  -t SECONDS        exit after SECONDS\n"
            "  -v                one line per frame with its fields and the CRC-32 of its data\n"
            "  -l                append the mean publish-to-receive latency to each line\n"
            "  -q                no per-second lines\n"
            "  --stats           print a summary line at exit\n"
            "  --retry-ms N      reconnect delay for a failed publisher (default 1000)\n"
            "  --nv21 WxH        go through the Android camera shim: NV21 preview of WxH per frame\n"
            "  --jpeg FILE       camera shim takePicture at exit: JPEG of the last frame\n");
}

int main(int argc, char **argv)
{
    tr_options o;
    tr_options_init(&o);
    char caller[64];
    snprintf(caller, sizeof caller, "/tinyros_echo_%d", (int)getpid());
    o.caller_id = caller;
    const char *topic = NULL, *jpeg_path = NULL;
    long max_frames = -1;
    double time_limit = -1;
    int verbose = 0, latency = 0, quiet = 0, stats = 0, nv_w = 0, nv_h = 0;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *next = i + 1 < argc ? argv[i + 1] : NULL;
        if (strstr(a, ":=")) continue;   /* ROS remapping / __name:= from roslaunch */
        if (!strcmp(a, "--master") && next) { o.master_uri = next; i++; }
        else if (!strcmp(a, "--caller-id") && next) { o.caller_id = next; i++; }
        else if (!strcmp(a, "--max-bytes") && next) { o.max_message_bytes = (uint32_t)strtoul(next, NULL, 0); i++; }
        else if (!strcmp(a, "--retry-ms") && next) { o.retry_ms = atoi(next); i++; }
        else if (!strcmp(a, "-n") && next) { max_frames = atol(next); i++; }
        else if (!strcmp(a, "-t") && next) { time_limit = atof(next); i++; }
        else if (!strcmp(a, "-v")) verbose = 1;
        else if (!strcmp(a, "-l")) latency = 1;
        else if (!strcmp(a, "-q")) quiet = 1;
        else if (!strcmp(a, "--stats")) stats = 1;
        else if (!strcmp(a, "--nv21") && next) {
            if (sscanf(next, "%dx%d", &nv_w, &nv_h) != 2 || nv_w <= 0 || nv_h <= 0 || (nv_w | nv_h) & 1) {
                fprintf(stderr, "tinyros_echo: --nv21 wants an even WxH, not \"%s\"\n", next);
                return 1;
            }
            i++;
        } else if (!strcmp(a, "--jpeg") && next) { jpeg_path = next; i++; }
        else if (!strcmp(a, "-h") || !strcmp(a, "--help")) { usage(); return 0; }
        else if (a[0] == '-' ) { fprintf(stderr, "tinyros_echo: unknown option %s\n", a); usage(); return 1; }
        else topic = a;
    }
    o.topic = topic;
    setvbuf(stdout, NULL, _IOLBF, 0);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    char err[512];
    /* --nv21/--jpeg run through the Android camera shim, as the emulator's camera would */
    tr_camera *cam = NULL;
    tr_sub *s;
    if (nv_w || jpeg_path) {
        if (!nv_w) { nv_w = 320; nv_h = 240; }
        cam = tr_camera_open(&o, nv_w, nv_h, err, sizeof err);
        s = cam ? tr_camera_subscriber(cam) : NULL;
    } else {
        s = tr_open(&o, err, sizeof err);
    }
    if (!s) { fprintf(stderr, "tinyros_echo: %s\n", err); return 1; }
    uint8_t *nv21 = cam ? (uint8_t *)malloc(tr_nv21_size(nv_w, nv_h)) : NULL;

    double t0 = mono_s(), tick = t0, lat_sum = 0, lat_all = 0, t_first = -1, t_last = -1;
    uint64_t received_first = 0;
    long frames = 0, tick_frames = 0, lat_n = 0;
    char shape[160] = "";
    int rc = 0;
    while (!g_stop) {
        double now = mono_s();
        if (time_limit >= 0 && now - t0 >= time_limit) { if (max_frames >= 0) rc = 2; break; }
        tr_image img;
        int w = cam ? tr_camera_preview(cam, nv21, 100, &img) : tr_wait(s, &img, 100);
        if (w < 0) { fprintf(stderr, "tinyros_echo: subscription ended\n"); rc = 3; break; }
        now = mono_s();
        if (w == 1) {
            if (t_first < 0) {
                tr_stats st0;
                tr_get_stats(s, &st0);
                t_first = now;
                received_first = st0.frames;
            }
            t_last = now;
            frames++;
            tick_frames++;
            double lat = wall_s() - (img.stamp_sec + img.stamp_nsec * 1e-9);
            lat_sum += lat;
            lat_all += lat;
            lat_n++;
            snprintf(shape, sizeof shape, "%ux%u %s", img.width, img.height, img.encoding);
            if (verbose)
                printf("frame seq=%u stamp=%u.%09u frame_id=%s %ux%u %s be=%u step=%u bytes=%u crc32=%08x\n",
                       img.seq, img.stamp_sec, img.stamp_nsec, img.frame_id, img.width, img.height,
                       img.encoding, img.is_bigendian, img.step, img.data_len,
                       tr_crc32(0, img.data, img.data_len));
            if (max_frames >= 0 && frames >= max_frames) break;
        }
        if (!quiet && now - tick >= 1.0) {
            double fps = tick_frames / (now - tick);
            if (tick_frames) {
                double ml = lat_sum / tick_frames;
                /* sim-time stamps (use_sim_time) are not comparable with the wall clock */
                if (latency && (ml > 3600 || ml < -3600))
                    printf("%s %.1f fps latency n/a (stamps are not wall-clock time)\n", shape, fps);
                else if (latency) printf("%s %.1f fps latency %.2f ms\n", shape, fps, 1000.0 * ml);
                else printf("%s %.1f fps\n", shape, fps);
            } else {
                tr_stats st;
                tr_get_stats(s, &st);
                printf("no frames on %s (%d publishers, %d connected)\n", topic ? topic : TR_DEFAULT_TOPIC,
                       st.publishers, st.connected);
            }
            tick = now;
            tick_frames = 0;
            lat_sum = 0;
        }
    }
    double elapsed = mono_s() - t0;
    if (jpeg_path) {
        uint8_t *j = NULL;
        size_t jl = 0;
        if (tr_camera_take_picture(cam, 0, 0, 90, &j, &jl)) {
            tr_camera_error(cam, err, sizeof err);
            fprintf(stderr, "tinyros_echo: takePicture: %s\n", err);
            rc = rc ? rc : 4;
        } else {
            FILE *f = fopen(jpeg_path, "wb");
            if (!f || fwrite(j, 1, jl, f) != jl) { fprintf(stderr, "tinyros_echo: cannot write %s\n", jpeg_path); rc = rc ? rc : 4; }
            if (f) fclose(f);
            free(j);
        }
    }
    if (stats) {
        tr_stats st;
        tr_get_stats(s, &st);
        /* rates from the first frame on, so start-up time does not count */
        double span = t_last - t_first;
        printf("stats frames=%ld received=%llu dropped=%llu bad_frames=%llu errors=%llu elapsed=%.3f fps=%.2f "
               "received_fps=%.2f latency_ms=%.3f\n", frames, (unsigned long long)st.frames,
               (unsigned long long)st.dropped, (unsigned long long)st.bad_frames, (unsigned long long)st.errors,
               elapsed, span > 0 ? (frames - 1) / span : 0.0,
               span > 0 ? (double)(st.frames - received_first) / span : 0.0, lat_n ? 1000.0 * lat_all / lat_n : 0.0);
    }
    if (cam) tr_camera_close(cam);
    else tr_close(s);
    free(nv21);
    return rc;
}
