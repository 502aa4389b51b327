// roscpp peer of tinyros for the integration tests and bench/tinyros.
//
//   tinyros_roscpp_peer pub TOPIC [--width W] [--height H] [--encoding E] [--rate HZ|0]
//                               [--count N] [--wait-subscribers N] [--quiet]
//   tinyros_roscpp_peer sub TOPIC [--seconds T]
//
// pub: frame i has frame_id "frame_<i>" and the same data as test/tinyros/image_pub.py;
//      prints "pub <i> <crc32>" unless --quiet (then only the first 8 bytes change per
//      frame, so an unthrottled publisher measures transport, not pattern generation).
// sub: prints one "WxH enc N fps latency L ms" line a second and a final
//      "stats frames=.. fps=.. latency_ms=.." line, like tinyros_echo --stats.
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/Image.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

extern "C" {
#include "tinyros/tinyros.h"
}

namespace {

int channels(const std::string &enc)
{
    if (enc == "rgb8" || enc == "bgr8") return 3;
    if (enc == "rgba8" || enc == "bgra8") return 4;
    return 1;
}

const char *arg(int argc, char **argv, const char *name, const char *def)
{
    for (int i = 1; i + 1 < argc; i++)
        if (!std::strcmp(argv[i], name)) return argv[i + 1];
    return def;
}

bool flag(int argc, char **argv, const char *name)
{
    for (int i = 1; i < argc; i++)
        if (!std::strcmp(argv[i], name)) return true;
    return false;
}

int run_pub(const std::string &topic, int argc, char **argv)
{
    ros::NodeHandle nh;
    int w = std::atoi(arg(argc, argv, "--width", "64"));
    int h = std::atoi(arg(argc, argv, "--height", "48"));
    std::string enc = arg(argc, argv, "--encoding", "rgb8");
    double rate = std::atof(arg(argc, argv, "--rate", "30"));
    long count = std::atol(arg(argc, argv, "--count", "0"));
    int wait_subs = std::atoi(arg(argc, argv, "--wait-subscribers", "0"));
    bool quiet = flag(argc, argv, "--quiet");
    ros::Publisher pub = nh.advertise<sensor_msgs::Image>(topic, 2);
    ros::WallTime until = ros::WallTime::now() + ros::WallDuration(30);
    while (ros::ok() && (int)pub.getNumSubscribers() < wait_subs && ros::WallTime::now() < until)
        ros::WallDuration(0.05).sleep();
    const uint32_t step = (uint32_t)(w * channels(enc));
    const size_t n = (size_t)step * h;
    std::vector<uint8_t> base(n);
    ros::WallDuration period(rate > 0 ? 1.0 / rate : 0.0);
    ros::WallTime next = ros::WallTime::now();
    for (long i = 0; ros::ok() && (count == 0 || i < count); i++) {
        sensor_msgs::ImagePtr msg(new sensor_msgs::Image);
        msg->height = h;
        msg->width = w;
        msg->encoding = enc;
        msg->is_bigendian = 0;
        msg->step = step;
        if (quiet) {
            msg->data = base;
            for (int k = 0; k < 8 && (size_t)k < n; k++) msg->data[k] = (uint8_t)(i >> (8 * k));
        } else {
            msg->data.resize(n);
            for (size_t k = 0; k < n; k++)
                msg->data[k] = (uint8_t)(((uint32_t)k * 7u + (uint32_t)i * 13u + ((uint32_t)k >> 11)) & 0xFFu);
        }
        char fid[32];
        std::snprintf(fid, sizeof fid, "frame_%ld", i);
        msg->header.frame_id = fid;
        msg->header.stamp = ros::Time::now();
        pub.publish(msg);
        if (!quiet) {
            std::printf("pub %ld %08x\n", i, tr_crc32(0, msg->data.data(), msg->data.size()));
            std::fflush(stdout);
        }
        if (rate > 0) {
            next += period;
            ros::WallTime now = ros::WallTime::now();
            if (next > now) (next - now).sleep();
        }
        ros::spinOnce();
    }
    ros::WallDuration(0.5).sleep();
    return 0;
}

struct SubStats {
    long frames = 0, tick_frames = 0;
    double lat_sum = 0, tick_lat = 0;
    ros::WallTime first, last;
    std::string shape;
    void cb(const sensor_msgs::ImageConstPtr &m)
    {
        double lat = (ros::Time::now() - m->header.stamp).toSec();
        last = ros::WallTime::now();
        if (frames == 0) first = last;
        frames++;
        tick_frames++;
        lat_sum += lat;
        tick_lat += lat;
        if (shape.empty())
            shape = std::to_string(m->width) + "x" + std::to_string(m->height) + " " + m->encoding;
    }
};

int run_sub(const std::string &topic, int argc, char **argv)
{
    ros::NodeHandle nh;
    double seconds = std::atof(arg(argc, argv, "--seconds", "5"));
    SubStats st;
    ros::Subscriber sub = nh.subscribe(topic, 10, &SubStats::cb, &st, ros::TransportHints().tcpNoDelay());
    ros::WallTime t0 = ros::WallTime::now(), tick = t0;
    while (ros::ok() && (ros::WallTime::now() - t0).toSec() < seconds) {
        ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.05));
        ros::WallTime now = ros::WallTime::now();
        if ((now - tick).toSec() >= 1.0) {
            double dt = (now - tick).toSec();
            if (st.tick_frames)
                std::printf("%s %.1f fps latency %.2f ms\n", st.shape.c_str(), st.tick_frames / dt,
                            1000.0 * st.tick_lat / st.tick_frames);
            else
                std::printf("no frames on %s\n", topic.c_str());
            std::fflush(stdout);
            st.tick_frames = 0;
            st.tick_lat = 0;
            tick = now;
        }
    }
    double el = (ros::WallTime::now() - t0).toSec();
    double span = st.frames > 1 ? (st.last - st.first).toSec() : 0.0;   // from the first frame on
    std::printf("stats frames=%ld elapsed=%.3f fps=%.2f latency_ms=%.3f\n", st.frames, el,
                span > 0 ? (st.frames - 1) / span : 0.0, st.frames ? 1000.0 * st.lat_sum / st.frames : 0.0);
    return 0;
}

}  // namespace

int main(int argc, char **argv)
{
    ros::init(argc, argv, "tinyros_roscpp_peer", ros::init_options::AnonymousName);
    if (argc < 3 || (std::strcmp(argv[1], "pub") && std::strcmp(argv[1], "sub"))) {
        std::fprintf(stderr, "usage: tinyros_roscpp_peer pub|sub TOPIC [options]\n");
        return 1;
    }
    std::string topic = argv[2];
    return !std::strcmp(argv[1], "pub") ? run_pub(topic, argc, argv) : run_sub(topic, argc, argv);
}
