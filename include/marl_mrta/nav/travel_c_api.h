/* Travel paths between poses as navigation plans them, for Python's ctypes (a C ABI):
 * libmarl_mrta_travel.so builds move_base's global costmap (static + inflation layers, from the
 * map as map_server publishes it and the move_base parameter files) and plans with the same
 * navfn core that move_base runs, from every pose to every other pose. ROS-free. */
#ifndef MARL_MRTA_NAV_TRAVEL_C_API_H
#define MARL_MRTA_NAV_TRAVEL_C_API_H

#ifdef __cplusplus
extern "C" {
#endif

typedef struct MarlMrtaTravel MarlMrtaTravel;

/* Builds the global costmap of `map_yaml` (a map_server YAML file) with the move_base parameters
 * in `nav_config_dir` (the files launch/include/robot_nav.launch loads, e.g. config/nav) and
 * plans the navfn path from every pose to every other pose, as move_base plans towards a goal.
 * poses: n * 3 doubles (x, y, yaw) in the map frame [m, m, rad]. On failure returns NULL and
 * writes one line (NUL-terminated, at most error_size bytes) into `error`; *failed_node is the
 * index of the pose that cannot be planned from/to (off the map or on its outer cells, in an
 * obstacle or the inscribed zone, or unreachable: the pose with the most failed plans), or -1
 * for a map / parameter error. On success *failed_node is -1 and `error` empty. Free the result with
 * marl_mrta_travel_free. */
MarlMrtaTravel* marl_mrta_travel_plan(const char* map_yaml, const char* nav_config_dir, int n, const double* poses,
                                      char* error, int error_size, int* failed_node);

/* The fastest the navigation's local planner drives [m/s]: DWA's min(max_vel_x, max_vel_trans). */
double marl_mrta_travel_max_speed(const MarlMrtaTravel* travel);

/* Points of the path from pose a to pose b (a != b): navfn's path, from the corner of a's cell
 * to b's position. 0 for indices out of range or a == b. */
int marl_mrta_travel_path_size(const MarlMrtaTravel* travel, int a, int b);

/* Writes path_size(a, b) * 2 doubles (x, y) [m] into xy. */
void marl_mrta_travel_path(const MarlMrtaTravel* travel, int a, int b, double* xy);

void marl_mrta_travel_free(MarlMrtaTravel* travel);

/* Reads a map_server map with the C++ reader (src/map/, as the simulator, navigation and the
 * travel planning read it), so that Python can hold it to its own reader. Returns the number of
 * cells (width * height) and sets *width and *height; when capacity is at least that, writes the
 * cells into data (nav_msgs/OccupancyGrid's order: row-major, the lowest row first). On a bad map
 * returns -1 and writes its one line into `error`. */
int marl_mrta_map_read(const char* map_yaml, signed char* data, int capacity, int* width, int* height, char* error,
                       int error_size);

#ifdef __cplusplus
}
#endif

#endif /* MARL_MRTA_NAV_TRAVEL_C_API_H */
