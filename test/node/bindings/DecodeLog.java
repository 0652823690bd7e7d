// Reads an LCM log with LCM's Java log reader and decodes every BORESIGHT_ATTITUDE and
// BORESIGHT_CALIBRATION event with the generated boresight_lcm classes (the jar lcm-spy loads).
// Prints "attitude N calibration M max_norm_error E".
import boresight_lcm.calibration_t;
import boresight_lcm.fused_attitude_t;
import java.io.EOFException;
import lcm.logging.Log;

public class DecodeLog {
  public static void main(String[] args) throws Exception {
    Log log = new Log(args[0], "r");
    long attitude = 0, calibration = 0;
    double worst = 0;
    while (true) {
      Log.Event e;
      try {
        e = log.readNext();
      } catch (EOFException end) {
        break;
      }
      if (e.channel.equals("BORESIGHT_ATTITUDE")) {
        fused_attitude_t a = new fused_attitude_t(e.data);
        double n = 0;
        for (double v : a.q_I_B) n += v * v;
        worst = Math.max(worst, Math.abs(Math.sqrt(n) - 1));
        ++attitude;
      } else if (e.channel.equals("BORESIGHT_CALIBRATION")) {
        new calibration_t(e.data);
        ++calibration;
      }
    }
    System.out.println("attitude " + attitude + " calibration " + calibration + " max_norm_error " + worst);
  }
}
