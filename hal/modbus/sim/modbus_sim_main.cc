// loom-modbus-sim: a Modbus device simulator for loom's controllers (turntable, LED controller,
// linear light; docs/hardware/modbus-register-maps.md), built on libmodbus's server side.
//
//   loom-modbus-sim --device turntable --tcp 127.0.0.1:0    # prints "listening tcp 127.0.0.1:PORT"
//   loom-modbus-sim --device leds --rtu                     # prints "listening rtu /dev/pts/N"
//
// TCP serves several clients at once (select loop). RTU creates a pty pair and serves its
// master side; clients open the printed slave path like a USB serial adapter. It only ever
// binds to the address given (tests use 127.0.0.1). Runs until killed.
#include <arpa/inet.h>
#include <modbus.h>
#include <netinet/in.h>
#include <pty.h>
#include <sys/select.h>
#include <termios.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <vector>

#include "hal/modbus/register_map.h"
#include "hal/modbus/sim/controller_model.h"

namespace {

namespace map = loom::hal::modbus_map;
using loom::hal::sim::ControllerKind;
using loom::hal::sim::ControllerModel;
using loom::hal::sim::ControllerSpec;
using Clock = std::chrono::steady_clock;

class Server {
 public:
  Server(modbus_t* context, const ControllerSpec& spec)
      : context_(context),
        mapping_(modbus_mapping_new(0, 0, map::kRegisterCount, 0)),
        model_(spec, mapping_->tab_registers),
        last_(Clock::now()) {}
  ~Server() { modbus_mapping_free(mapping_); }

  // Answers one request received in `query` (rc bytes).
  void Handle(const uint8_t* query, int rc) {
    const Clock::time_point now = Clock::now();
    model_.Advance(std::chrono::duration<double>(now - last_).count());
    last_ = now;
    const int header = modbus_get_header_length(context_);
    const int function = query[header];
    if (function == MODBUS_FC_WRITE_SINGLE_REGISTER || function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS) {
      const int address = (query[header + 1] << 8) | query[header + 2];
      std::vector<uint16_t> values;
      if (function == MODBUS_FC_WRITE_SINGLE_REGISTER) {
        values.push_back(static_cast<uint16_t>((query[header + 3] << 8) | query[header + 4]));
      } else {
        const int count = (query[header + 3] << 8) | query[header + 4];
        for (int i = 0; i < count && header + 6 + 2 * i + 1 < rc; ++i) {
          values.push_back(static_cast<uint16_t>((query[header + 6 + 2 * i] << 8) | query[header + 7 + 2 * i]));
        }
      }
      if (const int exception = model_.CheckWrite(address, values); exception != 0) {
        modbus_reply_exception(context_, query, exception);
        return;
      }
      modbus_reply(context_, query, rc, mapping_);
      model_.OnWritten(address, static_cast<int>(values.size()));
      return;
    }
    modbus_reply(context_, query, rc, mapping_);
  }

 private:
  modbus_t* context_;
  modbus_mapping_t* mapping_;
  ControllerModel model_;
  Clock::time_point last_;
};

int ServeTcp(const std::string& address, const ControllerSpec& spec) {
  const size_t colon = address.rfind(':');
  const std::string host = address.substr(0, colon);
  const int port = colon == std::string::npos ? 0 : std::stoi(address.substr(colon + 1));
  modbus_t* context = modbus_new_tcp(host.c_str(), port);
  const int listener = modbus_tcp_listen(context, 8);
  if (listener == -1) {
    std::cerr << "loom-modbus-sim: cannot listen on " << address << ": " << modbus_strerror(errno) << "\n";
    return 1;
  }
  sockaddr_in bound{};
  socklen_t length = sizeof(bound);
  getsockname(listener, reinterpret_cast<sockaddr*>(&bound), &length);
  std::printf("listening tcp %s:%d\n", host.c_str(), ntohs(bound.sin_port));
  std::fflush(stdout);

  Server server(context, spec);
  fd_set clients;
  FD_ZERO(&clients);
  FD_SET(listener, &clients);
  int max_fd = listener;
  std::vector<uint8_t> query(MODBUS_TCP_MAX_ADU_LENGTH);
  while (true) {
    fd_set ready = clients;
    if (select(max_fd + 1, &ready, nullptr, nullptr, nullptr) == -1) {
      if (errno == EINTR) continue;
      return 1;
    }
    for (int fd = 0; fd <= max_fd; ++fd) {
      if (!FD_ISSET(fd, &ready)) continue;
      if (fd == listener) {
        const int client = accept(listener, nullptr, nullptr);
        if (client != -1) {
          FD_SET(client, &clients);
          max_fd = std::max(max_fd, client);
        }
        continue;
      }
      modbus_set_socket(context, fd);
      const int rc = modbus_receive(context, query.data());
      if (rc > 0) {
        server.Handle(query.data(), rc);
      } else if (rc == -1) {
        close(fd);
        FD_CLR(fd, &clients);
      }
    }
  }
}

int ServeRtu(const ControllerSpec& spec, int unit) {
  int master = -1;
  int slave = -1;
  char slave_name[256];
  termios raw{};
  cfmakeraw(&raw);
  if (openpty(&master, &slave, slave_name, &raw, nullptr) == -1) {
    std::perror("loom-modbus-sim: openpty");
    return 1;
  }
  // The slave stays open here too, so the master never sees a hang-up between clients.
  modbus_t* context = modbus_new_rtu(slave_name, 115200, 'N', 8, 1);
  modbus_set_slave(context, unit);
  modbus_set_socket(context, master);
  std::printf("listening rtu %s\n", slave_name);
  std::fflush(stdout);
  Server server(context, spec);
  std::vector<uint8_t> query(MODBUS_RTU_MAX_ADU_LENGTH);
  while (true) {
    const int rc = modbus_receive(context, query.data());
    if (rc > 0) {
      server.Handle(query.data(), rc);
    } else if (rc == -1 && errno != ETIMEDOUT && errno != EMBBADCRC && errno != EMBBADDATA && errno != EINTR) {
      modbus_flush(context);
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Modbus simulator of loom's turntable, LED and linear-light controllers", "loom-modbus-sim");
  std::string device = "turntable";
  std::string tcp;
  bool rtu = false;
  int unit = 1;
  ControllerSpec spec;
  app.add_option("--device", device, "turntable, leds or linear-light")->required();
  app.add_option("--tcp", tcp, "serve Modbus TCP on HOST:PORT (port 0 = any free port)");
  app.add_flag("--rtu", rtu, "serve Modbus RTU on a new pty");
  app.add_option("--unit", unit, "RTU unit id");
  app.add_option("--serial", spec.serial, "serial number");
  app.add_option("--led-count", spec.led_count, "LEDs (leds)");
  app.add_option("--max-current-ma", spec.max_current_ma, "maximum LED current (leds)");
  app.add_option("--max-speed", spec.max_speed, "°/s (turntable) or mm/s (linear-light)");
  app.add_option("--travel-mm", spec.travel_mm, "carriage travel (linear-light)");
  CLI11_PARSE(app, argc, argv);
  if (device == "turntable") {
    spec.kind = ControllerKind::kTurntable;
  } else if (device == "leds") {
    spec.kind = ControllerKind::kLeds;
  } else if (device == "linear-light") {
    spec.kind = ControllerKind::kLinearLight;
  } else {
    std::cerr << "loom-modbus-sim: unknown --device '" << device << "'\n";
    return 2;
  }
  if (rtu == !tcp.empty()) {
    std::cerr << "loom-modbus-sim: give exactly one of --tcp HOST:PORT and --rtu\n";
    return 2;
  }
  return rtu ? ServeRtu(spec, unit) : ServeTcp(tcp, spec);
}
