"""``python -m graybox.simulation``: the demo fleet's faults and a summary of its telemetry."""
from graybox.simulation import demo_fleet, simulate_fleet


def main() -> None:
    """Print each demo vehicle's rows, mean and spread of its channels, and its faults."""
    spec = demo_fleet()
    for vehicle, (asset, frame) in zip(spec.vehicles, simulate_fleet(spec).items()):
        print(f"{asset}: {len(frame)} rows, shaft_speed {frame.shaft_speed.mean():8.2f} "
              f"+- {frame.shaft_speed.std():6.2f} rad/s, fuel_rate {frame.fuel_rate.mean():.3f} "
              f"kg/s, faults: {[f.to_dict() for f in vehicle.faults] or 'none'}")


if __name__ == "__main__":
    main()
