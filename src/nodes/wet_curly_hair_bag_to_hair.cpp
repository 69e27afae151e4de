// wet_curly_hair_bag_to_hair: the strands of a recorded bag as .hair frames (for
// wet_curly_hair_render or any .hair reader). Needs no ROS master.
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sys/stat.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "wet_curly_hair/Strands.h"
#include "wet_curly_hair/io/hair_file.h"

namespace {

const char* kUsage =
    "usage: wet_curly_hair_bag_to_hair [--topic TOPIC] [--stride N] [--count K] [--head-frame]\n"
    "                                  [--wet] BAG OUT_DIR\n"
    "Writes OUT_DIR/frame_%05d.hair for every N-th wet_curly_hair/Strands message of TOPIC\n"
    "(default /wet_curly_hair/strands), numbered by message index (so wet_curly_hair_render\n"
    "--fps RATE captions them with the time since the first message), and prints each path.\n"
    "  --stride N     keep every N-th message (default 1)\n"
    "  --count K      instead of a stride, K frames evenly spread over the bag\n"
    "  --head-frame   positions in the head frame (the message's head_pose undone), so that a\n"
    "                 renderer can draw the head at rest; default: world frame\n"
    "  --wet          the cohesion display positions (wet_positions) where present\n"
    "Saturation goes into the .hair transparency array (see io/hair_file.h).\n"
    "Exit codes: 0 done, 1 read or write failed, 2 bad arguments.\n";

}  // namespace

int main(int argc, char** argv) {
  using namespace wet_curly_hair;
  std::string topic = "/wet_curly_hair/strands", bag_path, out_dir;
  long stride = 1, count = 0;
  bool head_frame = false, wet = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "wet_curly_hair_bag_to_hair: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if (a == "--topic") {
      topic = value();
    } else if (a == "--stride") {
      stride = std::strtol(value(), nullptr, 10);
    } else if (a == "--count") {
      count = std::strtol(value(), nullptr, 10);
    } else if (a == "--head-frame") {
      head_frame = true;
    } else if (a == "--wet") {
      wet = true;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "wet_curly_hair_bag_to_hair: unknown option %s\n%s", a.c_str(), kUsage);
      return 2;
    } else if (bag_path.empty()) {
      bag_path = a;
    } else if (out_dir.empty()) {
      out_dir = a;
    } else {
      std::fprintf(stderr, "wet_curly_hair_bag_to_hair: unexpected argument %s\n", a.c_str());
      return 2;
    }
  }
  if (bag_path.empty() || out_dir.empty() || stride < 1 || count < 0) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  mkdir(out_dir.c_str(), 0755);
  try {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Read);
    rosbag::View view(bag, rosbag::TopicQuery(topic));
    const long total = static_cast<long>(view.size());
    if (total == 0) {
      std::fprintf(stderr, "wet_curly_hair_bag_to_hair: %s has no messages on %s\n",
                   bag_path.c_str(), topic.c_str());
      return 1;
    }
    if (count > 0) stride = std::max(1L, (total - 1) / std::max(1L, count - 1));
    long index = 0, written = 0;
    for (const rosbag::MessageInstance& m : view) {
      const long k = index++;
      if (k % stride != 0 || (count > 0 && written >= count)) continue;
      Strands::ConstPtr msg = m.instantiate<Strands>();
      if (!msg) {
        std::fprintf(stderr,
                     "wet_curly_hair_bag_to_hair: %s on %s is a %s, not a "
                     "wet_curly_hair/Strands\n",
                     bag_path.c_str(), topic.c_str(), m.getDataType().c_str());
        return 1;
      }
      const std::vector<float>& x =
          wet && !msg->wet_positions.empty() ? msg->wet_positions : msg->positions;
      Pose head;
      head.translation =
          Vec3(msg->head_pose.position.x, msg->head_pose.position.y, msg->head_pose.position.z);
      head.rotation = Quat(msg->head_pose.orientation.w, msg->head_pose.orientation.x,
                           msg->head_pose.orientation.y, msg->head_pose.orientation.z)
                          .normalized();
      Vec3List positions(x.size() / 3);
      for (size_t i = 0; i < positions.size(); ++i) {
        positions[i] = Vec3(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
        if (head_frame) positions[i] = head.applyInverse(positions[i]);
      }
      std::vector<double> saturation(msg->saturation.begin(), msg->saturation.end());
      io::HairFileData data;
      std::string why;
      if (!io::groomPositionsToHairChecked(msg->strand_offsets, positions, &saturation, &data,
                                           &why)) {
        std::fprintf(stderr, "wet_curly_hair_bag_to_hair: message %ld: %s\n", k, why.c_str());
        return 1;
      }
      char name[64];
      std::snprintf(name, sizeof(name), "/frame_%05ld.hair", k);
      if (!io::writeHairFile(out_dir + name, data, &why)) {
        std::fprintf(stderr, "wet_curly_hair_bag_to_hair: %s\n", why.c_str());
        return 1;
      }
      std::printf("%s%s\n", out_dir.c_str(), name);
      ++written;
    }
  } catch (const rosbag::BagException& e) {
    std::fprintf(stderr, "wet_curly_hair_bag_to_hair: %s: %s\n", bag_path.c_str(), e.what());
    return 1;
  }
  return 0;
}
