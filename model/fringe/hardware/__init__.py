"""From a calibration to the core: its configuration and tables (`corefiles`, `tables`, `closed_loop`), the ROM
images (`rom`), and the RTL itself run in simulation (`rtlsim`, `rtl_stream`)."""
