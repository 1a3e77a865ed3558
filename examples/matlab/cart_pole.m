% A cart-pole written for ode45, parameters in a struct.
% coordinates: x, theta
% p.mc = body/cart/mass
% p.mp = body/pole/mass
% p.c = body/pole/com[2]
% p.I = body/pole/inertia[1][1]
% p.kx = joint/x/damping
% p.g = -gravity[2]
function dydt = cart_pole(t, y, p, tau)
  x = y(1); th = y(2); dx = y(3); dth = y(4);
  M = [p.mc + p.mp, p.mp*p.c*cos(th); p.mp*p.c*cos(th), p.mp*p.c^2 + p.I];
  rhs = tau + [-p.kx*dx + p.mp*p.c*sin(th)*dth^2; p.mp*p.g*p.c*sin(th)];
  dydt = [dx; dth; M \ rhs];
end
